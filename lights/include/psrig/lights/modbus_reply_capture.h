#pragma once
// libmodbus's server side (modbus_reply, modbus_reply_exception) writes its
// answer straight to the context's socket. A Modbus server that must act on
// a request before the client hears it answered (psrigd's PLC server, the
// simulated LED driver of the tests) has libmodbus write into one end of a
// socket pair instead, and sends the captured bytes on itself.

#include <cstdint>
#include <modbus.h>
#include <vector>

#include "psrig/base/error.h"

namespace psrig::lights {

class ModbusReplyCapture {
 public:
  [[nodiscard]] static Result<ModbusReplyCapture> create();
  ModbusReplyCapture(ModbusReplyCapture&& other) noexcept;
  ModbusReplyCapture& operator=(ModbusReplyCapture&&) = delete;
  ModbusReplyCapture(const ModbusReplyCapture&) = delete;
  ModbusReplyCapture& operator=(const ModbusReplyCapture&) = delete;
  ~ModbusReplyCapture();

  // libmodbus's answer to `query` from `mapping` (a read, a write's echo, or
  // an exception for what the map lacks); empty if it wrote none. `ctx`
  // speaks to `client` again afterwards.
  [[nodiscard]] std::vector<std::uint8_t> reply(modbus_t* ctx, int client,
                                                const std::uint8_t* query, int length,
                                                modbus_mapping_t* mapping);
  // The exception `code` in answer to `query`.
  [[nodiscard]] std::vector<std::uint8_t> reply_exception(modbus_t* ctx, int client,
                                                          const std::uint8_t* query, unsigned code);

 private:
  ModbusReplyCapture(int write_end, int read_end) : write_end_(write_end), read_end_(read_end) {}
  [[nodiscard]] std::vector<std::uint8_t> take();

  int write_end_ = -1;  // the context's socket while libmodbus answers
  int read_end_ = -1;
};

}  // namespace psrig::lights
