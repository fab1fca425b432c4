#include "sim_modbus_driver.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <exception>
#include <fcntl.h>
#include <modbus.h>
#include <netinet/in.h>
#include <optional>
#include <poll.h>
#include <stdlib.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>
#include <utility>

#include "psrig/lights/modbus_reply_capture.h"

namespace psrig::test {

using lights::Clock;

// Everything the server thread owns at the C level.
struct SimModbusDriver::Link {
  modbus_t* ctx = nullptr;
  modbus_mapping_t* mapping = nullptr;
  bool tcp = true;
  int wake = -1;    // eventfd: stop the server thread
  int listen = -1;  // TCP
  int master = -1;  // RTU: our end of the pty
  int slave = -1;   // RTU: kept open so the master never sees a hang-up
                    // when the host closes and reopens its end
  // libmodbus answers into it; we decide what reaches the host.
  std::optional<lights::ModbusReplyCapture> capture;
  std::vector<int> clients;  // TCP connections

  ~Link() {
    for (const int fd : clients)
      ::close(fd);
    for (const int fd : {wake, listen, master, slave})
      if (fd >= 0) ::close(fd);
    if (mapping) modbus_mapping_free(mapping);
    if (ctx) modbus_free(ctx);  // frees only: the descriptors are ours
  }
};

namespace {

std::string system_error(const std::string& what) {
  return what + ": " + std::strerror(errno);
}

void write_all(int fd, const std::vector<std::uint8_t>& bytes, bool socket) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = socket ? ::send(fd, bytes.data() + done, bytes.size() - done, MSG_NOSIGNAL)
                             : ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;  // the host is gone; it will notice
    done += static_cast<std::size_t>(n);
  }
}

// An RTU server context on the pty master (never modbus_connect: it is open).
modbus_t* new_rtu_context(const std::string& device, int master, int slave) {
  modbus_t* ctx = modbus_new_rtu(device.c_str(), 19200, 'N', 8, 1);
  if (!ctx) return nullptr;
  modbus_set_socket(ctx, master);
  modbus_set_slave(ctx, slave);
  // Requests arrive whole; a stalled one must not hold the server (or its stop) for long.
  modbus_set_byte_timeout(ctx, 0, 100'000);
  return ctx;
}

int word(const std::uint8_t* bytes) {
  return (bytes[0] << 8) | bytes[1];
}

}  // namespace

SimModbusDriver::SimModbusDriver(const SimModbusDriverOptions& options, SwitchCallback on_switch)
    : options_(options), on_switch_(std::move(on_switch)), link_(std::make_unique<Link>()) {}

Result<std::unique_ptr<SimModbusDriver>> SimModbusDriver::start(
    const SimModbusDriverOptions& options, SwitchCallback on_switch) {
  if (options.transport != "tcp" && options.transport != "rtu")
    return std::unexpected(internal_error("simulated Modbus driver: transport must be tcp or rtu"));
  if (options.channels < 1 || options.channels > 64)
    return std::unexpected(internal_error("simulated Modbus driver: 1 to 64 channels"));
  std::unique_ptr<SimModbusDriver> driver(new SimModbusDriver(options, std::move(on_switch)));
  if (auto opened = driver->open(); !opened) return std::unexpected(opened.error());
  try {
    driver->thread_ = std::thread([raw = driver.get()] { raw->serve(); });
  } catch (const std::exception& e) {
    return std::unexpected(internal_error(std::string("simulated Modbus driver: ") + e.what()));
  }
  return driver;
}

Status SimModbusDriver::open() {
  Link& link = *link_;
  link.tcp = options_.transport == "tcp";
  link.wake = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (link.wake < 0) return std::unexpected(internal_error(system_error("eventfd")));
  auto captured = lights::ModbusReplyCapture::create();
  if (!captured) return std::unexpected(captured.error());
  link.capture.emplace(std::move(*captured));

  if (link.tcp) {
    link.ctx = modbus_new_tcp("127.0.0.1", 0);  // port 0: the kernel picks a free one
    if (!link.ctx) return std::unexpected(internal_error(system_error("modbus_new_tcp")));
    link.listen = modbus_tcp_listen(link.ctx, 4);
    if (link.listen < 0) return std::unexpected(internal_error(system_error("modbus_tcp_listen")));
    sockaddr_in address{};
    socklen_t size = sizeof address;
    if (::getsockname(link.listen, reinterpret_cast<sockaddr*>(&address), &size) != 0)
      return std::unexpected(internal_error(system_error("getsockname")));
    port_ = ntohs(address.sin_port);
  } else {
    link.master = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (link.master < 0) return std::unexpected(internal_error(system_error("posix_openpt")));
    char name[256] = {};
    if (::grantpt(link.master) != 0 || ::unlockpt(link.master) != 0 ||
        ::ptsname_r(link.master, name, sizeof name) != 0)
      return std::unexpected(internal_error(system_error("pseudo-terminal set-up")));
    link.slave = ::open(name, O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (link.slave < 0) return std::unexpected(internal_error(system_error(name)));
    // Raw from the start, so nothing is echoed before the host sets the line up.
    termios raw{};
    if (::tcgetattr(link.slave, &raw) == 0) {
      ::cfmakeraw(&raw);
      ::tcsetattr(link.slave, TCSANOW, &raw);
    }
    device_ = name;
    link.ctx = new_rtu_context(device_, link.master, options_.slave);
    if (!link.ctx) return std::unexpected(internal_error(system_error("modbus_new_rtu")));
  }
  if (modbus_set_slave(link.ctx, options_.slave) != 0)
    return std::unexpected(internal_error(system_error("modbus_set_slave")));
  // Requests arrive whole; a stalled one must not hold the server (or its stop) for long.
  modbus_set_byte_timeout(link.ctx, 0, 100'000);

  // One contiguous block per table, spanning every register in the map;
  // apply() refuses coil writes to the gaps.
  const auto& registers = options_.registers;
  int last_coil = registers.enable_coil + options_.channels - 1;
  first_coil_ = registers.enable_coil;
  if (registers.all_off_coil >= 0) {
    first_coil_ = std::min(first_coil_, registers.all_off_coil);
    last_coil = std::max(last_coil, registers.all_off_coil);
  }
  first_input_ = registers.status_register;
  int last_input = registers.status_register;
  if (registers.id_register >= 0) {
    first_input_ = std::min(first_input_, registers.id_register);
    last_input = std::max(last_input, registers.id_register + 1);
  }
  link.mapping = modbus_mapping_new_start_address(
      static_cast<unsigned>(first_coil_), static_cast<unsigned>(last_coil - first_coil_ + 1), 0, 0,
      static_cast<unsigned>(registers.intensity_register), static_cast<unsigned>(options_.channels),
      static_cast<unsigned>(first_input_), static_cast<unsigned>(last_input - first_input_ + 1));
  if (!link.mapping) return std::unexpected(internal_error(system_error("modbus_mapping_new")));
  for (int channel = 0; channel < options_.channels; ++channel)
    link.mapping->tab_registers[channel] =
        static_cast<std::uint16_t>(std::clamp(registers.intensity_full_scale, 0, 0xFFFF));
  if (registers.id_register >= 0) {
    const int id = registers.id_register - first_input_;
    link.mapping->tab_input_registers[id] = static_cast<std::uint16_t>(registers.device_id);
    link.mapping->tab_input_registers[id + 1] = options_.firmware;
  }
  return {};
}

SimModbusDriver::~SimModbusDriver() {
  stopping_ = true;
  if (link_->wake >= 0) {
    const std::uint64_t one = 1;
    [[maybe_unused]] const auto written = ::write(link_->wake, &one, sizeof one);
  }
  if (thread_.joinable()) thread_.join();
}

config::ModbusLights SimModbusDriver::host_config() const {
  config::ModbusLights config;
  config.transport = options_.transport;
  config.host = "127.0.0.1";
  config.port = port_;
  config.device = device_;
  config.slave = options_.slave;
  config.registers = options_.registers;
  return config;
}

std::vector<int> SimModbusDriver::leds_on() const {
  const std::scoped_lock lock(mutex_);
  std::vector<int> on;
  for (int channel = 0; channel < options_.channels; ++channel)
    if (coil_locked(channel)) on.push_back(channel);
  return on;
}

std::vector<std::uint16_t> SimModbusDriver::intensities() const {
  const std::scoped_lock lock(mutex_);
  return {link_->mapping->tab_registers, link_->mapping->tab_registers + options_.channels};
}

std::uint16_t SimModbusDriver::status() const {
  const std::scoped_lock lock(mutex_);
  return status_locked();
}

void SimModbusDriver::set_status(std::uint16_t status) {
  const std::scoped_lock lock(mutex_);
  status_locked() = status;
}

void SimModbusDriver::inject(ModbusFault fault, int requests, int exception_code) {
  const std::scoped_lock lock(mutex_);
  fault_ = fault;
  fault_left_ = fault == ModbusFault::none ? 0 : requests;
  exception_code_ = exception_code;
}

int SimModbusDriver::requests(int function) const {
  const std::scoped_lock lock(mutex_);
  if (function >= 0) return requests_by_function_.at(static_cast<std::size_t>(function & 0xFF));
  int total = 0;
  for (const int count : requests_by_function_)
    total += count;
  return total;
}

int SimModbusDriver::interlock_refusals() const {
  const std::scoped_lock lock(mutex_);
  return interlock_refusals_;
}

int SimModbusDriver::connections() const {
  const std::scoped_lock lock(mutex_);
  return connections_;
}

std::uint8_t& SimModbusDriver::coil_locked(int channel) const {
  return link_->mapping->tab_bits[options_.registers.enable_coil - first_coil_ + channel];
}

std::uint16_t& SimModbusDriver::status_locked() const {
  return link_->mapping->tab_input_registers[options_.registers.status_register - first_input_];
}

double SimModbusDriver::level_locked(int channel) const {
  const int full_scale = std::max(1, options_.registers.intensity_full_scale);
  const int raw = link_->mapping->tab_registers[channel];
  return std::min(raw, full_scale) / static_cast<double>(full_scale);
}

void SimModbusDriver::serve() {
  Link& link = *link_;
  while (!stopping_) {
    std::vector<pollfd> fds;
    fds.push_back({link.wake, POLLIN, 0});
    fds.push_back({link.tcp ? link.listen : link.master, POLLIN, 0});
    for (const int fd : link.clients)
      fds.push_back({fd, POLLIN, 0});
    if (::poll(fds.data(), fds.size(), -1) < 0) {
      if (errno == EINTR) continue;
      return;
    }
    if (fds[0].revents) return;

    // One request from `fd`; false when the connection should close.
    const auto receive = [&](int fd) {
      modbus_set_socket(link.ctx, fd);
      std::uint8_t query[MODBUS_MAX_ADU_LENGTH];
      const int length = modbus_receive(link.ctx, query);
      if (length < 0) {
        if (link.tcp) return false;  // closed by the host, or garbage
        modbus_flush(link.ctx);      // a broken RTU frame: resynchronise
        if (errno == EIO) ::usleep(10'000);
        return true;
      }
      if (length == 0) {
        // An RTU frame for another slave. libmodbus would now skip the next
        // frame as that slave's answer, but on this point-to-point line
        // nobody answers: start afresh so the host's next request counts.
        modbus_t* fresh = new_rtu_context(device_, link.master, options_.slave);
        if (fresh) {
          modbus_free(link.ctx);
          link.ctx = fresh;
        }
        return true;
      }
      return serve_request(fd, query, length);
    };

    if (fds[1].revents) {
      if (link.tcp) {
        const int client = ::accept4(link.listen, nullptr, nullptr, SOCK_CLOEXEC);
        if (client >= 0) {
          link.clients.push_back(client);
          const std::scoped_lock lock(mutex_);
          ++connections_;
        }
      } else {
        receive(link.master);
      }
    }
    for (std::size_t i = 2; i < fds.size(); ++i) {
      if (!fds[i].revents) continue;
      if (receive(fds[i].fd)) continue;
      ::close(fds[i].fd);
      std::erase(link.clients, fds[i].fd);
    }
  }
}

bool SimModbusDriver::serve_request(int fd, const std::uint8_t* query, int length) {
  Link& link = *link_;
  const int header = modbus_get_header_length(link.ctx);
  const int unit = query[header - 1];
  const int function = query[header];
  // libmodbus filters RTU frames by slave itself; on TCP the unit id is ours to check.
  if (link.tcp && unit != options_.slave && unit != MODBUS_TCP_SLAVE) return true;

  std::vector<Change> changes;
  std::vector<std::uint8_t> reply;
  ModbusFault fault = ModbusFault::none;
  Clock::time_point now;
  {
    const std::scoped_lock lock(mutex_);
    ++requests_by_function_[static_cast<std::size_t>(function)];
    if (fault_left_ != 0) {
      fault = fault_;
      if (fault_left_ > 0) --fault_left_;
    }
    if (fault == ModbusFault::no_answer) return true;
    if (fault == ModbusFault::drop_connection) return !link.tcp;
    now = Clock::now();
    reply = fault == ModbusFault::exception ? capture_exception(fd, query, exception_code_)
                                            : apply(fd, query, length, changes);
  }
  // The world learns of the switch before the host hears it is done.
  if (on_switch_) {
    for (const auto& change : changes) {
      try {
        on_switch_(change.channel, change.on, change.level, now);
      } catch (...) {  // a broken callback must not take the driver down
      }
    }
  }
  if (fault == ModbusFault::lost_reply || reply.empty()) return true;
  if (fault == ModbusFault::bad_crc) {
    if (link.tcp)
      reply[0] ^= 0xFF;  // no CRC on TCP: break the transaction id instead
    else
      reply.back() ^= 0xFF;
  }
  write_all(fd, reply, link.tcp);
  return true;
}

std::vector<std::uint8_t> SimModbusDriver::apply(int fd, const std::uint8_t* query, int length,
                                                 std::vector<Change>& changes) {
  Link& link = *link_;
  const int header = modbus_get_header_length(link.ctx);
  const int function = query[header];
  const int first = options_.registers.enable_coil;
  const int all_off = options_.registers.all_off_coil;
  const int channels = options_.channels;
  std::vector<bool> before(static_cast<std::size_t>(channels));
  std::vector<std::uint16_t> levels_before(static_cast<std::size_t>(channels));
  for (int channel = 0; channel < channels; ++channel) {
    before[channel] = coil_locked(channel) != 0;
    levels_before[channel] = link.mapping->tab_registers[channel];
  }

  // A coil write, decoded: which coils, to what. Others go to libmodbus as they are.
  std::vector<std::pair<int, bool>> coil_writes;
  const std::uint8_t* pdu = query + header;
  const int pdu_length = length - header;
  if (function == MODBUS_FC_WRITE_SINGLE_COIL && pdu_length >= 5) {
    coil_writes.emplace_back(word(pdu + 1), word(pdu + 3) == 0xFF00);
  } else if (function == MODBUS_FC_WRITE_MULTIPLE_COILS && pdu_length >= 6) {
    const int address = word(pdu + 1);
    const int count = word(pdu + 3);
    if (pdu_length >= 6 + pdu[5] && pdu[5] == (count + 7) / 8)
      for (int i = 0; i < count; ++i)
        coil_writes.emplace_back(address + i, (pdu[6 + i / 8] >> (i % 8)) & 1);
  }
  // What the write would leave on: refused when it touches a coil that is
  // not in the map, or would light a second LED.
  std::vector<bool> after = before;
  bool all_off_requested = false;
  for (const auto& [address, value] : coil_writes) {
    if (address >= first && address < first + channels) {
      after[address - first] = value;
    } else if (address == all_off) {
      all_off_requested = all_off_requested || value;
    } else {
      return capture_exception(fd, query, MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
    }
  }
  if (all_off_requested) std::fill(after.begin(), after.end(), false);
  if (std::count(after.begin(), after.end(), true) > 1) {
    status_locked() |= kModbusStatusInterlock;
    ++interlock_refusals_;
    return capture_exception(fd, query, MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
  }

  auto reply = link.capture->reply(link.ctx, fd, query, length, link.mapping);
  if (all_off_requested) {
    // The command coil acts and reads back 0, like a push button.
    for (int channel = 0; channel < channels; ++channel)
      coil_locked(channel) = 0;
    link.mapping->tab_bits[all_off - first_coil_] = 0;
  }

  // Offs before ons, so that no observer ever sees two LEDs on.
  bool any_on = false;
  for (int channel = 0; channel < channels; ++channel) {
    const bool on = coil_locked(channel) != 0;
    any_on = any_on || on;
    if (!before[channel] || on) continue;
    changes.push_back({channel, false, 0.0});
    log_.record(channel, false);
  }
  for (int channel = 0; channel < channels; ++channel) {
    if (coil_locked(channel) == 0) continue;
    if (!before[channel]) log_.record(channel, true);
    const bool level_changed = link.mapping->tab_registers[channel] != levels_before[channel];
    if (!before[channel] || level_changed)
      changes.push_back({channel, true, level_locked(channel)});
  }
  // The interlock bit latches until the host acknowledges with every LED off.
  if (!coil_writes.empty() && !any_on) status_locked() &= ~kModbusStatusInterlock;
  return reply;
}

std::vector<std::uint8_t> SimModbusDriver::capture_exception(int fd, const std::uint8_t* query,
                                                             int code) {
  Link& link = *link_;
  return link.capture->reply_exception(link.ctx, fd, query, static_cast<unsigned>(code));
}

}  // namespace psrig::test
