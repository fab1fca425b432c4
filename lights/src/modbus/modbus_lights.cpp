#include "psrig/lights/modbus_lights.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <exception>
#include <functional>
#include <modbus.h>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "psrig/base/log.h"

namespace psrig::lights {

namespace {

constexpr const char* kEnableKey = "lights.modbus.registers.enable_coil";
constexpr const char* kAllOffKey = "lights.modbus.registers.all_off_coil";
constexpr const char* kIntensityKey = "lights.modbus.registers.intensity_register";
constexpr const char* kStatusKey = "lights.modbus.registers.status_register";
constexpr const char* kIdKey = "lights.modbus.registers.id_register";
constexpr const char* kDeviceIdKey = "lights.modbus.registers.device_id";

// Device code never throws: a std::exception that escapes (bad_alloc, say)
// becomes an error here.
template <class F>
auto guarded(F f) -> decltype(f()) {
  try {
    return f();
  } catch (const std::exception& e) {
    return std::unexpected(internal_error(std::string("modbus lights: ") + e.what()));
  }
}

std::string hex(unsigned value) {
  static constexpr char digits[] = "0123456789abcdef";
  std::string text = "0x0000";
  for (int i = 5; i >= 2; --i, value >>= 4)
    text[i] = digits[value & 0xF];
  return text;
}

std::string range(int first, int count) {
  return count == 1 ? std::to_string(first)
                    : std::to_string(first) + "-" + std::to_string(first + count - 1);
}

// Errors worth another attempt: the request or its answer got lost or
// mangled on the way. An exception response is the driver's considered
// answer, and asking again would not change it (unless it is busy).
bool retryable(int error) {
  switch (error) {
    case ETIMEDOUT:
    case EMBBADCRC:
    case EMBBADDATA:
    case EMBBADSLAVE:
    case EMBMDATA:
    case EMBUNKEXC:
    case EMBBADEXC:
    case EMBXSBUSY:
    case EMBXACK:
    case ECONNRESET:
    case ECONNREFUSED:
    case ECONNABORTED:
    case EPIPE:
    case ENOTCONN:
    case EBADF:
    case EIO:
      return true;
    default:
      return false;
  }
}

// Errors after which the connection (or the serial device) is reopened.
bool link_lost(int error) {
  return error == ECONNRESET || error == ECONNABORTED || error == EPIPE || error == ENOTCONN ||
         error == EBADF || error == EIO || error == ECONNREFUSED;
}

bool is_exception(int error) {
  return error >= EMBXILFUN && error <= EMBXGTAR;
}

struct ContextDeleter {
  void operator()(modbus_t* ctx) const {
    modbus_close(ctx);
    modbus_free(ctx);
  }
};
using Context = std::unique_ptr<modbus_t, ContextDeleter>;

Error config_error(const std::string& key, const std::string& message) {
  return bad_input({}, "lights." + key, message);
}

std::optional<Error> validate(const config::LightsConfig& config) {
  const auto& modbus = config.modbus;
  const auto& registers = modbus.registers;
  const bool rtu = modbus.transport == "rtu";
  if (modbus.transport != "tcp" && !rtu)
    return config_error("modbus.transport",
                        "must be \"tcp\" or \"rtu\", not \"" + modbus.transport + "\"");
  if (config.channels < 1 || config.channels > 64)
    return config_error("channels", "must be 1 to 64 for a Modbus driver");
  if (!config.intensity.empty() && static_cast<int>(config.intensity.size()) != config.channels)
    return config_error("intensity", "needs one level per channel (" +
                                         std::to_string(config.channels) + ") or none");
  for (const double level : config.intensity)
    if (!(level >= 0 && level <= 1)) return config_error("intensity", "levels are 0 to 1");
  if (rtu) {
    if (modbus.device.empty()) return config_error("modbus.device", "names the serial port");
    if (modbus.baud <= 0) return config_error("modbus.baud", "must be positive, e.g. 19200");
    if (modbus.parity != 'N' && modbus.parity != 'E' && modbus.parity != 'O')
      return config_error("modbus.parity", "must be N, E or O");
    if (modbus.data_bits < 5 || modbus.data_bits > 8)
      return config_error("modbus.data_bits", "must be 5 to 8");
    if (modbus.stop_bits != 1 && modbus.stop_bits != 2)
      return config_error("modbus.stop_bits", "must be 1 or 2");
    if (modbus.slave < 1 || modbus.slave > 247)
      return config_error("modbus.slave", "RTU slave ids are 1 to 247");
  } else {
    if (modbus.host.empty()) return config_error("modbus.host", "names the driver's address");
    if (modbus.port < 1 || modbus.port > 65535)
      return config_error("modbus.port", "must be 1 to 65535");
    if (modbus.slave < 0 || modbus.slave > 255)
      return config_error("modbus.slave", "TCP unit ids are 0 to 255");
  }
  if (modbus.timeout_ms < 1 || modbus.timeout_ms > 60'000)
    return config_error("modbus.timeout_ms", "must be 1 to 60000");
  if (modbus.retries < 0 || modbus.retries > 10)
    return config_error("modbus.retries", "must be 0 to 10");
  const auto address_ok = [](int first, int count) {
    return first >= 0 && first + count <= 0x10000;
  };
  if (!address_ok(registers.enable_coil, config.channels))
    return config_error("modbus.registers.enable_coil", "coils must lie within 0 to 65535");
  if (registers.all_off_coil != -1 && !address_ok(registers.all_off_coil, 1))
    return config_error("modbus.registers.all_off_coil", "must be -1 (none) or 0 to 65535");
  if (registers.all_off_coil >= registers.enable_coil &&
      registers.all_off_coil < registers.enable_coil + config.channels)
    return config_error(
        "modbus.registers.all_off_coil",
        "lies among the enable coils " + range(registers.enable_coil, config.channels));
  if (!address_ok(registers.intensity_register, config.channels))
    return config_error("modbus.registers.intensity_register",
                        "registers must lie within 0 to 65535");
  if (registers.intensity_full_scale < 1 || registers.intensity_full_scale > 0xFFFF)
    return config_error("modbus.registers.intensity_full_scale", "must be 1 to 65535");
  if (!address_ok(registers.status_register, 1))
    return config_error("modbus.registers.status_register", "must be 0 to 65535");
  if (registers.id_register != -1 && !address_ok(registers.id_register, 2))
    return config_error("modbus.registers.id_register", "must be -1 (none) or 0 to 65534");
  if (registers.device_id < 0 || registers.device_id > 0xFFFF)
    return config_error("modbus.registers.device_id", "must be 0 to 65535");
  return std::nullopt;
}

// One Modbus request: what it does in words and the configuration key of
// the register it touches, both for the error if it fails.
struct Exchange {
  std::string what;  // "switching LED 1 on (writing coils 0-2, lights.modbus....)"
  std::string key;
  std::function<int(modbus_t*)> run;
};

class ModbusLights final : public LightController {
 public:
  ModbusLights(config::LightsConfig config, Context ctx)
      : config_(std::move(config)), ctx_(std::move(ctx)) {}

  ~ModbusLights() override {
    try {
      const std::scoped_lock lock(mutex_);
      if (!started_) return;  // start() already turned all off, or never wrote a thing
      if (auto off = all_off_locked(); !off)
        logger_->error("could not turn the LEDs off on closing: {}", off.error().describe());
    } catch (...) {  // a destructor never throws; the driver's own safety remains
    }
  }

  ModbusLights(const ModbusLights&) = delete;
  ModbusLights& operator=(const ModbusLights&) = delete;

  // At open: proves the device answers and is the LED driver (before
  // writing anything to it), turns everything off, sets the configured
  // intensities and refuses a driver that reports a fault.
  Status start() {
    const std::scoped_lock lock(mutex_);
    if (modbus_connect(ctx_.get()) != 0) return std::unexpected(connect_error(errno));
    connected_ = true;
    if (auto identified = check_identity_locked(); !identified) return identified;
    if (auto off = all_off_locked(); !off) return off;
    if (auto confirmed = confirm_all_off_locked(); !confirmed) return confirmed;
    std::vector<std::uint16_t> values;
    for (int channel = 0; channel < config_.channels; ++channel)
      values.push_back(raw_level(config_.intensity.empty() ? 1.0 : config_.intensity[channel]));
    const int first = config_.modbus.registers.intensity_register;
    if (auto written = transact({"writing the intensities (holding registers " +
                                     range(first, config_.channels) + ", " + kIntensityKey + ")",
                                 kIntensityKey,
                                 [&](modbus_t* ctx) {
                                   return modbus_write_registers(ctx, first, config_.channels,
                                                                 values.data());
                                 }});
        !written)
      return written;
    if (auto healthy = check_status_locked("at start-up"); !healthy) return healthy;
    started_ = true;
    return {};
  }

  [[nodiscard]] int channel_count() const override { return config_.channels; }

  [[nodiscard]] Status turn_on(int channel) override {
    return guarded([&]() -> Status {
      const std::scoped_lock lock(mutex_);
      if (auto valid = check_channel(channel); !valid) return valid;
      // One request for every coil: the driver never sees two on at once.
      std::vector<std::uint8_t> bits(static_cast<std::size_t>(config_.channels), 0);
      bits[static_cast<std::size_t>(channel)] = 1;
      const int first = config_.modbus.registers.enable_coil;
      auto written =
          transact({"switching LED " + std::to_string(channel) + " on (writing coils " +
                        range(first, config_.channels) + ", " + kEnableKey + ")",
                    kEnableKey, [&](modbus_t* ctx) {
                      return modbus_write_bits(ctx, first, config_.channels, bits.data());
                    }});
      if (!written) return fail_safe(written.error());
      if (on_ && *on_ != channel) log_.record(*on_, false);
      if (on_ != channel) log_.record(channel, true);
      on_ = channel;
      if (auto healthy =
              check_status_locked("after switching LED " + std::to_string(channel) + " on");
          !healthy)
        return fail_safe(healthy.error());
      return {};
    });
  }

  [[nodiscard]] Status all_off() override {
    return guarded([&]() -> Status {
      const std::scoped_lock lock(mutex_);
      return all_off_locked();
    });
  }

  [[nodiscard]] Status set_intensity(int channel, double level) override {
    return guarded([&]() -> Status {
      const std::scoped_lock lock(mutex_);
      if (auto valid = check_channel(channel); !valid) return valid;
      if (!(level >= 0 && level <= 1))
        return std::unexpected(
            bad_input({}, "lights.intensity", "levels are 0 to 1, not " + std::to_string(level)));
      const int address = config_.modbus.registers.intensity_register + channel;
      const std::uint16_t value = raw_level(level);
      auto written = transact(
          {"setting LED " + std::to_string(channel) + "'s intensity (writing holding register " +
               std::to_string(address) + ", " + kIntensityKey + ")",
           kIntensityKey,
           [&](modbus_t* ctx) { return modbus_write_register(ctx, address, value); }});
      if (!written) return fail_safe(written.error());
      return {};
    });
  }

  [[nodiscard]] std::string describe() const override {
    std::string text = "modbus LED driver";
    if (firmware_)
      text += " " + hex(static_cast<unsigned>(config_.modbus.registers.device_id)) + " firmware " +
              std::to_string(*firmware_ >> 8) + "." + std::to_string(*firmware_ & 0xFF);
    return text + ", " + where();
  }

 private:
  [[nodiscard]] std::uint16_t raw_level(double level) const {
    const double full_scale = config_.modbus.registers.intensity_full_scale;
    return static_cast<std::uint16_t>(std::lround(std::clamp(level, 0.0, 1.0) * full_scale));
  }

  // "rtu /dev/ttyUSB0 19200 8N1, slave 1" or "tcp 10.0.0.7:502, slave 1".
  [[nodiscard]] std::string where() const {
    const auto& modbus = config_.modbus;
    if (modbus.transport == "rtu")
      return "rtu " + modbus.device + " " + std::to_string(modbus.baud) + " " +
             std::to_string(modbus.data_bits) + modbus.parity + std::to_string(modbus.stop_bits) +
             ", slave " + std::to_string(modbus.slave);
    return "tcp " + modbus.host + ":" + std::to_string(modbus.port) + ", slave " +
           std::to_string(modbus.slave);
  }

  // The key that says where the driver is: where to look when it is silent.
  [[nodiscard]] std::string endpoint_key() const {
    return config_.modbus.transport == "rtu" ? "lights.modbus.device" : "lights.modbus.host";
  }

  [[nodiscard]] std::string fix() const {
    if (config_.modbus.transport == "rtu")
      return "Check the wiring (A/B, ground, termination) and the driver's power, and that "
             "lights.modbus.slave, lights.modbus.baud, lights.modbus.parity, "
             "lights.modbus.data_bits and lights.modbus.stop_bits match the driver's settings; "
             "`psrig devices` lists the serial ports found.";
    return "Check the network cable and the driver's power (it should answer ping), and that "
           "lights.modbus.host, lights.modbus.port and lights.modbus.slave match the driver's "
           "settings.";
  }

  [[nodiscard]] Error with_key(Error error, std::string key) const {
    error.key = std::move(key);
    return error;
  }

  [[nodiscard]] Error connect_error(int error) const {
    const auto& modbus = config_.modbus;
    if (modbus.transport == "rtu")
      return with_key(io_error(modbus.device, "cannot open the Modbus serial port (" + where() +
                                                  "): " + modbus_strerror(error) +
                                                  ". Check lights.modbus.device, that the "
                                                  "adapter is plugged in and that psrig may use "
                                                  "it (group dialout); `psrig devices` lists the "
                                                  "serial ports found."),
                      endpoint_key());
    return with_key(io_error({}, "cannot connect to the Modbus LED driver (" + where() +
                                     "): " + modbus_strerror(error) + ". " + fix()),
                    endpoint_key());
  }

  [[nodiscard]] Error failure(const Exchange& exchange, int error, int attempts) const {
    const std::string prefix = "Modbus LED driver (" + where() + "): ";
    if (is_exception(error)) {
      std::string hint = "See the driver's manual and its front panel.";
      if (error == EMBXILADD || error == EMBXILFUN)
        hint =
            "lights.modbus.registers does not match the driver's register map "
            "(lights/README.md describes the default one).";
      return with_key(
          io_error({}, prefix + "refused " + exchange.what + ": " + modbus_strerror(error) +
                           " (exception " + std::to_string(error - MODBUS_ENOBASE) + "). " + hint),
          exchange.key);
    }
    const std::string how = link_lost(error)     ? "lost the connection"
                            : error == ETIMEDOUT ? "no answer"
                                                 : "no valid answer";
    return with_key(
        io_error({}, prefix + how + " " + exchange.what + " after " + std::to_string(attempts) +
                         (attempts == 1 ? " attempt" : " attempts") + " (timeout " +
                         std::to_string(config_.modbus.timeout_ms) +
                         " ms each, lights.modbus.timeout_ms): " + modbus_strerror(error) + ". " +
                         fix()),
        endpoint_key());
  }

  // Runs one request, with lights.modbus.retries more attempts after a lost
  // or garbled exchange; reconnects first when the link broke.
  [[nodiscard]] Status transact(const Exchange& exchange) {
    const int attempts = 1 + config_.modbus.retries;
    int error = 0;
    for (int attempt = 1; attempt <= attempts; ++attempt) {
      if (!connected_) {
        if (modbus_connect(ctx_.get()) != 0) {
          error = errno;
          if (!retryable(error)) return std::unexpected(connect_error(error));
          continue;
        }
        connected_ = true;
      }
      if (exchange.run(ctx_.get()) != -1) return {};
      error = errno;
      if (!retryable(error)) return std::unexpected(failure(exchange, error, attempt));
      if (attempt < attempts)
        logger_->warn("modbus LED driver ({}): {} failed ({}), attempt {} of {}", where(),
                      exchange.what, modbus_strerror(error), attempt, attempts);
      if (link_lost(error)) {
        modbus_close(ctx_.get());
        connected_ = false;
      } else {
        modbus_flush(ctx_.get());  // a late or broken answer must not pass for the next one
      }
    }
    return std::unexpected(failure(exchange, error, attempts));
  }

  // The all-off coil reaches every output the driver has, even ones this
  // configuration does not know of; without one, clear the enable coils.
  [[nodiscard]] Status all_off_locked() {
    const auto& registers = config_.modbus.registers;
    Status written;
    if (registers.all_off_coil >= 0) {
      const int address = registers.all_off_coil;
      written =
          transact({"switching every LED off (writing coil " + std::to_string(address) + ", " +
                        kAllOffKey + ")",
                    kAllOffKey, [&](modbus_t* ctx) { return modbus_write_bit(ctx, address, 1); }});
    } else {
      const std::vector<std::uint8_t> bits(static_cast<std::size_t>(config_.channels), 0);
      const int first = registers.enable_coil;
      written = transact({"switching every LED off (writing coils " +
                              range(first, config_.channels) + ", " + kEnableKey + ")",
                          kEnableKey, [&](modbus_t* ctx) {
                            return modbus_write_bits(ctx, first, config_.channels, bits.data());
                          }});
    }
    if (!written) return written;
    log_.record(-1, false);
    on_.reset();
    return {};
  }

  // Reads the enable coils back: they must exist where the map says, and
  // all off (through the all-off coil, perhaps) must have cleared them.
  [[nodiscard]] Status confirm_all_off_locked() {
    const int first = config_.modbus.registers.enable_coil;
    std::vector<std::uint8_t> bits(static_cast<std::size_t>(config_.channels), 0);
    if (auto read = transact({"reading back the enable coils (coils " +
                                  range(first, config_.channels) + ", " + kEnableKey + ")",
                              kEnableKey,
                              [&](modbus_t* ctx) {
                                return modbus_read_bits(ctx, first, config_.channels, bits.data());
                              }});
        !read)
      return read;
    const auto lit = std::find(bits.begin(), bits.end(), 1);
    if (lit == bits.end()) return {};
    const int channel = static_cast<int>(lit - bits.begin());
    // The all-off coil did not do it; clearing the enable coils still may.
    std::fill(bits.begin(), bits.end(), 0);
    if (modbus_write_bits(ctx_.get(), first, config_.channels, bits.data()) == -1)
      logger_->error("modbus LED driver ({}): clearing the enable coils failed too: {}", where(),
                     modbus_strerror(errno));
    return std::unexpected(with_key(
        io_error({}, "Modbus LED driver (" + where() + ") still has LED " +
                         std::to_string(channel) + " on (coil " + std::to_string(first + channel) +
                         ") after switching every LED off: " + kAllOffKey + " or " + kEnableKey +
                         " does not match the driver's register map (lights/README.md "
                         "describes the default one)."),
        config_.modbus.registers.all_off_coil >= 0 ? kAllOffKey : kEnableKey));
  }

  // Reads the id and firmware version; a device that is not the LED driver
  // (a wrong slave id on a shared bus, say) is left untouched.
  [[nodiscard]] Status check_identity_locked() {
    const auto& registers = config_.modbus.registers;
    if (registers.id_register < 0) return {};
    const int address = registers.id_register;
    std::uint16_t words[2] = {};
    if (auto read = transact(
            {"reading the device id and firmware version (input registers " + range(address, 2) +
                 ", " + kIdKey + ")",
             kIdKey,
             [&](modbus_t* ctx) { return modbus_read_input_registers(ctx, address, 2, words); }});
        !read)
      return read;
    if (words[0] != registers.device_id)
      return std::unexpected(with_key(
          io_error({}, "the Modbus device at " + where() + " has device id " + hex(words[0]) +
                           " in input register " + std::to_string(address) + ", not " +
                           hex(static_cast<unsigned>(registers.device_id)) +
                           ": it is not the LED driver psrig expects, so nothing was written to "
                           "it. Check lights.modbus.slave, and " +
                           kDeviceIdKey + " and " + kIdKey + " against the driver's manual."),
          kDeviceIdKey));
    firmware_ = words[1];
    return {};
  }

  [[nodiscard]] Status check_status_locked(const std::string& when) {
    const int address = config_.modbus.registers.status_register;
    std::uint16_t status = 0;
    if (auto read = transact(
            {"reading the status (input register " + std::to_string(address) + ", " + kStatusKey +
                 ")",
             kStatusKey,
             [&](modbus_t* ctx) { return modbus_read_input_registers(ctx, address, 1, &status); }});
        !read)
      return read;
    if (status == 0) return {};
    return std::unexpected(with_key(
        io_error({}, "Modbus LED driver (" + where() + ") reports a fault " + when +
                         ": status input register " + std::to_string(address) + " = " +
                         hex(status) +
                         ". Check the LEDs and their cables, the driver's temperature and its "
                         "front panel, then power-cycle it (lights/README.md lists the "
                         "status bits)."),
        kStatusKey));
  }

  [[nodiscard]] Status check_channel(int channel) const {
    if (channel >= 0 && channel < config_.channels) return {};
    return std::unexpected(internal_error("modbus lights: no channel " + std::to_string(channel) +
                                          " (there are " + std::to_string(config_.channels) + ")"));
  }

  // After any failure: every LED off, best effort, and the first error back.
  [[nodiscard]] Status fail_safe(Error error) {
    if (auto off = all_off_locked(); !off) {
      error.message += " Turning every LED off failed too: " + off.error().message;
    } else {
      error.message += " Every LED is off.";
    }
    return std::unexpected(std::move(error));
  }

  config::LightsConfig config_;
  std::mutex mutex_;  // libmodbus contexts are not thread-safe
  Context ctx_;
  bool connected_ = false;
  bool started_ = false;
  std::optional<int> on_;                  // the LED we switched on, as far as we know
  std::optional<std::uint16_t> firmware_;  // major << 8 | minor, when the driver tells
  std::shared_ptr<spdlog::logger> logger_ = logger("lights");
};

}  // namespace

Result<std::unique_ptr<LightController>> open_modbus_lights(const config::LightsConfig& config) {
  return guarded([&]() -> Result<std::unique_ptr<LightController>> {
    if (auto invalid = validate(config)) return std::unexpected(*invalid);
    const auto& modbus = config.modbus;
    Context ctx(modbus.transport == "rtu"
                    ? modbus_new_rtu(modbus.device.c_str(), modbus.baud, modbus.parity,
                                     modbus.data_bits, modbus.stop_bits)
                    : modbus_new_tcp_pi(modbus.host.c_str(), std::to_string(modbus.port).c_str()));
    if (!ctx)
      return std::unexpected(
          bad_input({}, "lights.modbus",
                    std::string("libmodbus rejected the settings: ") + modbus_strerror(errno)));
    if (modbus_set_slave(ctx.get(), modbus.slave) != 0)
      return std::unexpected(
          bad_input({}, "lights.modbus.slave",
                    std::string("libmodbus rejected the slave id: ") + modbus_strerror(errno)));
    const auto timeout_us = static_cast<std::uint32_t>(modbus.timeout_ms) * 1000u;
    modbus_set_response_timeout(ctx.get(), timeout_us / 1'000'000u, timeout_us % 1'000'000u);
    // A reply cut short must not stretch an attempt past the configured timeout either.
    modbus_set_byte_timeout(ctx.get(), timeout_us / 1'000'000u, timeout_us % 1'000'000u);
    modbus_set_error_recovery(ctx.get(), MODBUS_ERROR_RECOVERY_NONE);  // we retry ourselves

    auto lights = std::make_unique<ModbusLights>(config, std::move(ctx));
    if (auto started = lights->start(); !started) return std::unexpected(started.error());
    return std::unique_ptr<LightController>(std::move(lights));
  });
}

}  // namespace psrig::lights
