#include "psrig/lights/modbus_reply_capture.h"

#include <cerrno>
#include <cstring>
#include <string>
#include <sys/socket.h>
#include <unistd.h>
#include <utility>

namespace psrig::lights {

Result<ModbusReplyCapture> ModbusReplyCapture::create() {
  int ends[2] = {-1, -1};
  // Non-blocking: take() reads until the pair is empty, never waits.
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0, ends) != 0)
    return std::unexpected(internal_error(std::string("socketpair: ") + std::strerror(errno)));
  return ModbusReplyCapture(ends[0], ends[1]);
}

ModbusReplyCapture::ModbusReplyCapture(ModbusReplyCapture&& other) noexcept
    : write_end_(std::exchange(other.write_end_, -1)),
      read_end_(std::exchange(other.read_end_, -1)) {}

ModbusReplyCapture::~ModbusReplyCapture() {
  for (const int fd : {write_end_, read_end_})
    if (fd >= 0) ::close(fd);
}

std::vector<std::uint8_t> ModbusReplyCapture::reply(modbus_t* ctx, int client,
                                                    const std::uint8_t* query, int length,
                                                    modbus_mapping_t* mapping) {
  modbus_set_socket(ctx, write_end_);
  const bool replied = modbus_reply(ctx, query, length, mapping) >= 0;
  modbus_set_socket(ctx, client);
  return replied ? take() : std::vector<std::uint8_t>{};
}

std::vector<std::uint8_t> ModbusReplyCapture::reply_exception(modbus_t* ctx, int client,
                                                              const std::uint8_t* query,
                                                              unsigned code) {
  modbus_set_socket(ctx, write_end_);
  const bool replied = modbus_reply_exception(ctx, query, code) >= 0;
  modbus_set_socket(ctx, client);
  return replied ? take() : std::vector<std::uint8_t>{};
}

std::vector<std::uint8_t> ModbusReplyCapture::take() {
  std::vector<std::uint8_t> bytes;
  std::uint8_t buffer[MODBUS_MAX_ADU_LENGTH];
  ssize_t n = 0;
  while ((n = ::read(read_end_, buffer, sizeof buffer)) > 0)
    bytes.insert(bytes.end(), buffer, buffer + n);
  return bytes;
}

}  // namespace psrig::lights
