#pragma once
// Errors as values: processing and device code return Result<T> and never
// throw; programs turn an Error into a message and an exit code at the top.

#include <expected>
#include <filesystem>
#include <string>

namespace psrig::processing {

enum class ErrorKind {
  bad_input,  // the user's files or arguments are wrong: exit code 2
  io,         // the machine failed us (disk full, permission): exit code 1
  internal,   // a bug or an unexpected library failure: exit code 1
};

struct Error {
  ErrorKind kind = ErrorKind::internal;
  std::string message;         // what is wrong and, where it helps, the fix
  std::filesystem::path file;  // the file concerned, if any
  std::string key;             // the scan.json key concerned, e.g. "lights[1].direction"
  int line = 0;                // 1-based position in `file`, when known
  int column = 0;

  // "FILE:LINE:COL: KEY: MESSAGE", leaving out the parts not known.
  [[nodiscard]] std::string describe() const;
};

template <class T>
using Result = std::expected<T, Error>;
using Status = std::expected<void, Error>;

[[nodiscard]] Error bad_input(std::filesystem::path file, std::string key, std::string message);
[[nodiscard]] Error io_error(std::filesystem::path file, std::string message);
[[nodiscard]] Error internal_error(std::string message);

// The process exit code for an error: 2 for bad input, 1 otherwise.
[[nodiscard]] int exit_code(const Error& error);

}  // namespace psrig::processing
