#include "psrig/daemon/modbus_server.h"

#include <algorithm>
#include <arpa/inet.h>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <exception>
#include <fcntl.h>
#include <modbus.h>
#include <mutex>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <optional>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <thread>
#include <unistd.h>
#include <utility>
#include <vector>

#include "psrig/base/log.h"
#include "psrig/firmware_host/modbus_reply_capture.h"

namespace psrig::daemon {

namespace {

std::shared_ptr<spdlog::logger> plc_log() {
  return logger("modbus");
}

std::string system_error(const std::string& what) {
  return what + ": " + std::strerror(errno);
}

timeval to_timeval(std::chrono::milliseconds duration) {
  const auto us = std::chrono::duration_cast<std::chrono::microseconds>(duration).count();
  return {static_cast<time_t>(us / 1'000'000), static_cast<suseconds_t>(us % 1'000'000)};
}

// The low 32 bits, negatives as 0: counters wrap as a PLC's do, and ids
// (catalogue row ids, from 1) never reach 2^32.
std::uint32_t low32(std::int64_t value) {
  return value < 0 ? 0u : static_cast<std::uint32_t>(static_cast<std::uint64_t>(value));
}

// False when the client is gone or stopped reading (SO_SNDTIMEO).
bool send_all(int fd, const std::vector<std::uint8_t>& bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::send(fd, bytes.data() + done, bytes.size() - done, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace

// Everything the server thread owns at the C level, and the PLC-side state.
struct ModbusServer::Impl {
  Impl(ScanControl& control_in, ModbusServerOptions options_in)
      : control(control_in), options(std::move(options_in)) {}

  ~Impl() {
    for (const int fd : clients)
      ::close(fd);
    for (const int fd : {wake, listen})
      if (fd >= 0) ::close(fd);
    if (mapping) modbus_mapping_free(mapping);
    if (ctx) modbus_free(ctx);  // frees only: the descriptors are ours
  }

  Status open();
  void serve();
  bool serve_one(int fd);  // false: close this connection
  void refresh(const DaemonStatus& status);
  void act(bool trigger_edge, bool lights_off_edge);
  void put32(int address, std::uint32_t value) const {
    // High word first ("ABCD"): big-endian throughout, as each Modbus word already is.
    mapping->tab_input_registers[address] = static_cast<std::uint16_t>(value >> 16);
    mapping->tab_input_registers[address + 1] = static_cast<std::uint16_t>(value & 0xFFFF);
  }

  ScanControl& control;
  const ModbusServerOptions options;
  modbus_t* ctx = nullptr;
  modbus_mapping_t* mapping = nullptr;
  int wake = -1;    // eventfd: stop the server thread
  int listen = -1;  // the listening socket
  // libmodbus answers into it; the answer is sent on after acting.
  std::optional<firmware_host::ModbusReplyCapture> capture;
  std::vector<int> clients;
  std::thread thread;
  std::mutex stop_mutex;  // one stop() joins
  std::atomic<bool> stopping = false;

  // The PLC's own view, touched by the server thread only. `refused`: the
  // PLC's last command failed, latched until a trigger is accepted.
  std::optional<ScanErrorCode> refused;
  std::int64_t triggered_scan = 0;

  mutable std::mutex counters_mutex;
  ModbusServerCounters counters;
};

Status ModbusServer::Impl::open() {
  in_addr parsed{};
  if (::inet_pton(AF_INET, options.address.c_str(), &parsed) != 1)
    return std::unexpected(bad_input({}, "daemon.modbus_address",
                                     "\"" + options.address +
                                         "\" is not an IPv4 address to listen on (e.g. "
                                         "127.0.0.1, or 0.0.0.0 for every interface)"));
  if (options.port < 0 || options.port > 65535)
    return std::unexpected(bad_input(
        {}, "daemon.modbus_port",
        std::to_string(options.port) + " is not a TCP port (1 to 65535; 0: any free one)"));
  if (options.max_clients < 1)
    return std::unexpected(internal_error("Modbus server: max_clients must be at least 1"));

  wake = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (wake < 0) return std::unexpected(internal_error(system_error("eventfd")));
  auto captured = firmware_host::ModbusReplyCapture::create();
  if (!captured) return std::unexpected(captured.error());
  capture.emplace(std::move(*captured));
  ctx = modbus_new_tcp(options.address.c_str(), options.port);
  if (!ctx) return std::unexpected(internal_error(system_error("modbus_new_tcp")));
  const timeval timeout = to_timeval(options.request_timeout);
  modbus_set_byte_timeout(ctx, static_cast<std::uint32_t>(timeout.tv_sec),
                          static_cast<std::uint32_t>(timeout.tv_usec));
  modbus_set_indication_timeout(ctx, static_cast<std::uint32_t>(timeout.tv_sec),
                                static_cast<std::uint32_t>(timeout.tv_usec));

  listen = modbus_tcp_listen(ctx, options.max_clients);
  if (listen < 0) {
    const bool privileged = errno == EACCES && options.port < 1024;
    Error error = io_error(
        {}, system_error("cannot listen for the PLC on tcp " + options.address + ":" +
                         std::to_string(options.port)) +
                (privileged ? " (ports below 1024 need CAP_NET_BIND_SERVICE, which "
                              "psrigd.service grants; or choose daemon.modbus_port above 1023)"
                            : ""));
    error.key = "daemon.modbus_port";
    return std::unexpected(std::move(error));
  }
  ::fcntl(listen, F_SETFD, FD_CLOEXEC);

  mapping = modbus_mapping_new_start_address(0, modbus_coil::count, 0, modbus_input::count, 0, 0, 0,
                                             modbus_register::count);
  if (!mapping) return std::unexpected(internal_error(system_error("modbus_mapping_new")));
  return {};
}

Result<std::unique_ptr<ModbusServer>> ModbusServer::start(ScanControl& control,
                                                          const ModbusServerOptions& options) {
  auto impl = std::make_unique<Impl>(control, options);
  if (auto opened = impl->open(); !opened) return std::unexpected(opened.error());
  sockaddr_in address{};
  socklen_t size = sizeof address;
  if (::getsockname(impl->listen, reinterpret_cast<sockaddr*>(&address), &size) != 0)
    return std::unexpected(internal_error(system_error("getsockname")));
  const int port = ntohs(address.sin_port);
  // The registers hold a real status before the first client can ask.
  try {
    impl->refresh(control.status());
  } catch (const std::exception& e) {
    return std::unexpected(internal_error(std::string("Modbus server: status: ") + e.what()));
  }
  std::unique_ptr<ModbusServer> server(new ModbusServer(std::move(impl), port));
  try {
    server->impl_->thread = std::thread([raw = server->impl_.get()] { raw->serve(); });
  } catch (const std::exception& e) {
    return std::unexpected(internal_error(std::string("Modbus server: thread: ") + e.what()));
  }
  plc_log()->info("serving the PLC on {}", server->endpoint());
  return server;
}

ModbusServer::ModbusServer(std::unique_ptr<Impl> impl, int port)
    : impl_(std::move(impl)), port_(port) {}

ModbusServer::~ModbusServer() {
  stop();
}

void ModbusServer::stop() {
  const std::scoped_lock lock(impl_->stop_mutex);
  if (!impl_->thread.joinable()) return;
  impl_->stopping = true;
  const std::uint64_t one = 1;
  [[maybe_unused]] const auto written = ::write(impl_->wake, &one, sizeof one);
  impl_->thread.join();
  // Connections close now, not at destruction: a stopped server serves nobody.
  for (const int fd : impl_->clients)
    ::close(fd);
  impl_->clients.clear();
  ::close(impl_->listen);
  impl_->listen = -1;
  plc_log()->info("stopped serving the PLC on {}", endpoint());
}

std::string ModbusServer::endpoint() const {
  return "tcp " + impl_->options.address + ":" + std::to_string(port_);
}

ModbusServerCounters ModbusServer::counters() const {
  const std::scoped_lock lock(impl_->counters_mutex);
  return impl_->counters;
}

void ModbusServer::Impl::serve() {
  std::vector<pollfd> fds;
  while (!stopping) {
    fds.clear();
    fds.push_back({wake, POLLIN, 0});
    fds.push_back({listen, POLLIN, 0});
    for (const int fd : clients)
      fds.push_back({fd, POLLIN, 0});
    if (::poll(fds.data(), fds.size(), -1) < 0) {
      if (errno == EINTR) continue;
      plc_log()->error("Modbus server stops: {}", system_error("poll"));
      return;
    }
    if (fds[0].revents) return;

    std::vector<int> closed;
    for (std::size_t i = 2; i < fds.size(); ++i) {
      if (!fds[i].revents) continue;
      bool keep = false;
      try {
        keep = serve_one(fds[i].fd);
      } catch (const std::exception& e) {  // never let one request end the server
        plc_log()->error("Modbus request failed: {}", e.what());
      }
      if (!keep) closed.push_back(fds[i].fd);
    }
    for (const int fd : closed) {
      ::close(fd);
      std::erase(clients, fd);
      const std::scoped_lock lock(counters_mutex);
      ++counters.dropped;
      counters.clients = static_cast<int>(clients.size());
    }

    if (fds[1].revents & POLLIN) {
      const int client = ::accept4(listen, nullptr, nullptr, SOCK_CLOEXEC);
      if (client < 0) {
        // Out of descriptors, the listening socket stays readable: without
        // a pause the loop would spin a core until one frees up.
        if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS || errno == ENOMEM) {
          plc_log()->error("cannot accept a Modbus connection: {}", std::strerror(errno));
          std::this_thread::sleep_for(std::chrono::milliseconds(100));
        }
        continue;  // or the peer gave up already
      }
      const std::scoped_lock lock(counters_mutex);
      if (static_cast<int>(clients.size()) >= options.max_clients) {
        ++counters.rejected;  // counted before the client can see the close
        ::close(client);
        plc_log()->warn("refused a Modbus connection: {} clients already connected",
                        clients.size());
        continue;
      }
      // A client that never reads its replies must not block the server on send.
      const timeval timeout = to_timeval(options.request_timeout);
      ::setsockopt(client, SOL_SOCKET, SO_SNDTIMEO, &timeout, sizeof timeout);
      const int one = 1;
      ::setsockopt(client, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
      clients.push_back(client);
      ++counters.connections;
      counters.clients = static_cast<int>(clients.size());
    }
  }
}

bool ModbusServer::Impl::serve_one(int fd) {
  modbus_set_socket(ctx, fd);
  std::uint8_t query[MODBUS_TCP_MAX_ADU_LENGTH];
  const int length = modbus_receive(ctx, query);
  if (length < 0) {
    // Hung up, garbage (an impossible length) or stalled past request_timeout.
    if (errno != ECONNRESET)
      plc_log()->debug("dropping a Modbus client: {}", modbus_strerror(errno));
    return false;
  }
  if (length == 0) return true;  // not for us (RTU only; kept for completeness)

  refresh(control.status());
  const bool trigger_before = mapping->tab_bits[modbus_coil::trigger] != 0;
  const bool lights_off_before = mapping->tab_bits[modbus_coil::lights_off] != 0;
  // libmodbus answers from the mapping (reads, coil writes, and exceptions
  // for functions and addresses the map does not have), captured, so the
  // edge acts before the PLC hears its write acknowledged.
  const auto reply = capture->reply(ctx, fd, query, length, mapping);
  {
    const std::scoped_lock lock(counters_mutex);
    ++counters.requests;
  }
  act(!trigger_before && mapping->tab_bits[modbus_coil::trigger] != 0,
      !lights_off_before && mapping->tab_bits[modbus_coil::lights_off] != 0);
  return send_all(fd, reply);
}

void ModbusServer::Impl::refresh(const DaemonStatus& status) {
  const bool idle_or_error =
      status.state == DaemonState::idle || status.state == DaemonState::error;
  const bool running =
      status.state == DaemonState::scanning || status.state == DaemonState::processing;
  const bool failed = status.state == DaemonState::error;

  mapping->tab_input_bits[modbus_input::ready] = idle_or_error && status.queue_length == 0;
  mapping->tab_input_bits[modbus_input::busy] = running || status.queue_length > 0;
  mapping->tab_input_bits[modbus_input::error] = failed || refused.has_value();
  mapping->tab_input_bits[modbus_input::scanning] = status.state == DaemonState::scanning;

  ScanErrorCode error = ScanErrorCode::none;
  if (refused)
    error = *refused;
  else if (failed)
    error = status.last_error_code == ScanErrorCode::none ? ScanErrorCode::internal
                                                          : status.last_error_code;

  auto* registers = mapping->tab_input_registers;
  registers[modbus_register::state] = static_cast<std::uint16_t>(status.state);
  registers[modbus_register::progress] =
      static_cast<std::uint16_t>(std::clamp(status.progress_percent, 0, 100));
  put32(modbus_register::last_scan_id, low32(status.last_scan.value_or(0)));
  registers[modbus_register::error_code] = static_cast<std::uint16_t>(error);
  put32(modbus_register::scans_completed, static_cast<std::uint32_t>(status.scans_completed));
  registers[modbus_register::queue_length] =
      static_cast<std::uint16_t>(std::min<std::size_t>(status.queue_length, 0xFFFF));
  put32(modbus_register::uptime_seconds,
        low32(std::chrono::duration_cast<std::chrono::seconds>(status.uptime).count()));
  put32(modbus_register::scans_failed, static_cast<std::uint32_t>(status.scans_failed));
  put32(modbus_register::current_scan_id, low32(status.current_scan.value_or(0)));
  std::uint64_t accepted = 0;
  std::uint64_t refusals = 0;
  {
    const std::scoped_lock lock(counters_mutex);
    accepted = counters.triggers_accepted;
    refusals = counters.triggers_refused;
  }
  registers[modbus_register::triggers_accepted] = static_cast<std::uint16_t>(accepted);
  registers[modbus_register::triggers_refused] = static_cast<std::uint16_t>(refusals);
  put32(modbus_register::triggered_scan_id, low32(triggered_scan));
}

void ModbusServer::Impl::act(bool trigger_edge, bool lights_off_edge) {
  if (lights_off_edge) {
    // First, so that one write raising both coils ends with the LEDs off.
    if (auto off = control.lights_off(); off) {
      plc_log()->info("PLC: lights off");
      const std::scoped_lock lock(counters_mutex);
      ++counters.lights_off;
    } else {
      refused = ScanErrorCode::lights;
      plc_log()->error("PLC: lights off failed: {}", off.error().describe());
    }
  }
  if (trigger_edge) {
    ScanSubmission submission;
    submission.source = "modbus";
    auto submitted = control.submit(std::move(submission));
    if (submitted) {
      refused.reset();
      triggered_scan = *submitted;
      plc_log()->info("PLC: scan {} queued", *submitted);
      const std::scoped_lock lock(counters_mutex);
      ++counters.triggers_accepted;
    } else {
      // Why, as the PLC reads it: a stopping daemon aborts, a full queue
      // says so (its code), anything else is the catalogue's storage.
      refused = control.status().state == DaemonState::stopping   ? ScanErrorCode::aborted
                : submitted.error().code == ErrorCode::queue_full ? ScanErrorCode::queue_full
                                                                  : ScanErrorCode::storage;
      plc_log()->warn("PLC: trigger refused: {}", submitted.error().describe());
      const std::scoped_lock lock(counters_mutex);
      ++counters.triggers_refused;
    }
  }
  if (trigger_edge || lights_off_edge) refresh(control.status());
}

}  // namespace psrig::daemon
