#pragma once
// Errors as values: device, processing and service code return Result<T>
// and never throw; programs turn an Error into a message and an exit code
// at the top. These names live in `psrig` itself: every module speaks them.

#include <expected>
#include <filesystem>
#include <string>

namespace psrig {

enum class ErrorKind {
  bad_input,  // the user's files or arguments are wrong: exit code 2
  io,         // the machine failed us (disk full, permission): exit code 1
  internal,   // a bug or an unexpected library failure: exit code 1
};

// What failed, for code that acts on an error: callers decide on this,
// never on the message text, which is for people.
enum class ErrorCode {
  unspecified,
  lights,      // an LED or its driver failed, or the safety layer cut one off
  camera,      // the camera failed, timed out, or its frames never fit the lighting
  disk_full,   // the storage has no room left
  queue_full,  // a service refused more work for now; try again later
  unavailable,  // a service this one needs (the shared catalogue's database) is away; try again later
};

struct Error {
  ErrorKind kind = ErrorKind::internal;
  std::string message;         // what is wrong and, where it helps, the fix
  std::filesystem::path file;  // the file concerned, if any
  std::string key;             // the scan.json key, rig.toml key or option concerned, if any
  int line = 0;                // 1-based position in `file`, when known
  int column = 0;
  ErrorCode code = ErrorCode::unspecified;

  // "FILE:LINE:COL: KEY: MESSAGE", leaving out the parts not known.
  [[nodiscard]] std::string describe() const;

  // The same error with `code` set, for chaining at the place that knows.
  [[nodiscard]] Error with(ErrorCode c) &&;
};

template <class T>
using Result = std::expected<T, Error>;
using Status = std::expected<void, Error>;

[[nodiscard]] Error bad_input(std::filesystem::path file, std::string key, std::string message);
[[nodiscard]] Error io_error(std::filesystem::path file, std::string message);
[[nodiscard]] Error internal_error(std::string message);

// The process exit code for an error: 2 for bad input, 1 otherwise.
[[nodiscard]] int exit_code(const Error& error);

}  // namespace psrig
