#include "psrig/base/error.h"

#include <utility>

namespace psrig {

std::string Error::describe() const {
  std::string text;
  if (!file.empty()) {
    text += file.string();
    if (line > 0) text += ":" + std::to_string(line) + ":" + std::to_string(column);
    text += ": ";
  }
  if (!key.empty()) text += key + ": ";
  text += message;
  return text;
}

Error Error::with(ErrorCode c) && {
  code = c;
  return std::move(*this);
}

Error bad_input(std::filesystem::path file, std::string key, std::string message) {
  return {ErrorKind::bad_input, std::move(message), std::move(file), std::move(key)};
}

Error io_error(std::filesystem::path file, std::string message) {
  return {ErrorKind::io, std::move(message), std::move(file), {}};
}

Error internal_error(std::string message) {
  return {ErrorKind::internal, std::move(message), {}, {}};
}

int exit_code(const Error& error) {
  return error.kind == ErrorKind::bad_input ? 2 : 1;
}

}  // namespace psrig
