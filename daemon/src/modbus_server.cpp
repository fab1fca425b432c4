#include "psrig/daemon/modbus_server.h"

#include <algorithm>
#include <arpa/inet.h>
#include <array>
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
#include <string>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <thread>
#include <unistd.h>
#include <utility>
#include <vector>

#include "psrig/base/log.h"
#include "psrig/lights/modbus_reply_capture.h"

namespace psrig::daemon {

namespace {

std::shared_ptr<spdlog::logger> plc_log() {
  return logger("modbus");
}

std::string system_error(const std::string& what) {
  return what + ": " + std::strerror(errno);
}

// The low 32 bits, negatives as 0: counters wrap as a PLC's do, and ids
// (catalogue row ids, from 1) never reach 2^32.
std::uint32_t low32(std::int64_t value) {
  return value < 0 ? 0u : static_cast<std::uint32_t>(static_cast<std::uint64_t>(value));
}

using Clock = std::chrono::steady_clock;

// The MBAP header: transaction id, protocol id (0: Modbus), length (of the
// unit id and the PDU that follow), unit id.
constexpr std::size_t kHeader = 7;
// The length field's bounds: a unit id and a function code at least, a
// 253-byte PDU at most.
constexpr int kMinLength = 2;
constexpr int kMaxLength = MODBUS_TCP_MAX_ADU_LENGTH - 6;

// The function codes libmodbus answers from the mapping: the bits and
// registers of the register map, and the holding-register functions (there
// are none, so libmodbus refuses their addresses with exception 2).
// Everything else is exception 1 at once: libmodbus itself never answers
// function 7 and answers other unknown codes only after sleeping its
// response timeout.
bool served(int function) {
  switch (function) {
    case MODBUS_FC_READ_COILS:
    case MODBUS_FC_READ_DISCRETE_INPUTS:
    case MODBUS_FC_READ_HOLDING_REGISTERS:
    case MODBUS_FC_READ_INPUT_REGISTERS:
    case MODBUS_FC_WRITE_SINGLE_COIL:
    case MODBUS_FC_WRITE_SINGLE_REGISTER:
    case MODBUS_FC_WRITE_MULTIPLE_COILS:
    case MODBUS_FC_WRITE_MULTIPLE_REGISTERS:
    case MODBUS_FC_MASK_WRITE_REGISTER:
    case MODBUS_FC_WRITE_AND_READ_REGISTERS:
      return true;
    default:
      return false;
  }
}

// Whether a served function's PDU (function code first) has the size its
// fields say: libmodbus reads them without knowing how much arrived.
bool pdu_size_right(const std::uint8_t* pdu, int size) {
  switch (pdu[0]) {
    case MODBUS_FC_WRITE_MULTIPLE_COILS:
    case MODBUS_FC_WRITE_MULTIPLE_REGISTERS:
      return size >= 6 && size == 6 + pdu[5];
    case MODBUS_FC_MASK_WRITE_REGISTER:
      return size == 7;
    case MODBUS_FC_WRITE_AND_READ_REGISTERS:
      return size >= 10 && size == 10 + pdu[9];
    default:
      return size == 5;
  }
}

std::string peer_name(const sockaddr_in& peer) {
  char text[INET_ADDRSTRLEN] = {};
  ::inet_ntop(AF_INET, &peer.sin_addr, text, sizeof text);
  return std::string(text) + ":" + std::to_string(ntohs(peer.sin_port));
}

}  // namespace

// One connection: the bytes of its request so far, and when it must be whole.
struct ModbusConnection {
  int fd = -1;
  std::string peer;
  std::array<std::uint8_t, MODBUS_TCP_MAX_ADU_LENGTH> buffer{};
  std::size_t size = 0;
  Clock::time_point deadline{};  // while size > 0
};

// Everything the server thread owns at the C level, and the PLC-side state.
struct ModbusServer::Impl {
  Impl(ScanControl& control_in, ModbusServerOptions options_in)
      : control(control_in), options(std::move(options_in)) {}

  ~Impl() {
    for (const ModbusConnection& client : clients)
      ::close(client.fd);
    for (const int fd : {wake, listen})
      if (fd >= 0) ::close(fd);
    if (mapping) modbus_mapping_free(mapping);
    if (ctx) modbus_free(ctx);  // frees only: the descriptors are ours
  }

  Status open();
  void serve();
  void accept_one();
  // Reads what `client` sent and answers each whole request; false: close it.
  bool receive(ModbusConnection& client);
  bool answer(ModbusConnection& client, const std::uint8_t* frame, int length);
  void drop(std::size_t index, const char* why);
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
  std::optional<lights::ModbusReplyCapture> capture;
  std::vector<in_addr_t> allowed;  // options.allow, parsed; empty: anyone
  std::vector<ModbusConnection> clients;
  std::thread thread;
  std::mutex stop_mutex;  // one stop() joins
  std::atomic<bool> stopping = false;

  // The PLC's own view, touched by the server thread only. `refused`: the
  // PLC's last command failed, latched until a trigger is accepted.
  std::optional<catalogue::ScanErrorCode> refused;
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
  for (const std::string& peer : options.allow) {
    in_addr allowed_peer{};
    if (::inet_pton(AF_INET, peer.c_str(), &allowed_peer) != 1)
      return std::unexpected(bad_input({}, "daemon.modbus_allow",
                                       "\"" + peer +
                                           "\" is not an IPv4 address of a PLC (e.g. "
                                           "\"192.0.2.10\")"));
    allowed.push_back(allowed_peer.s_addr);
  }

  wake = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (wake < 0) return std::unexpected(internal_error(system_error("eventfd")));
  auto captured = lights::ModbusReplyCapture::create();
  if (!captured) return std::unexpected(captured.error());
  capture.emplace(std::move(*captured));
  ctx = modbus_new_tcp(options.address.c_str(), options.port);
  if (!ctx) return std::unexpected(internal_error(system_error("modbus_new_tcp")));
  // The server never calls modbus_receive: it assembles each request
  // itself. modbus_reply sleeps the response timeout before some exceptions
  // (a bad count of values) "to flush": one microsecond, the least it takes.
  modbus_set_response_timeout(ctx, 0, 1);

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
  // accept4 must not block when the peer gave up between poll and accept.
  ::fcntl(listen, F_SETFL, ::fcntl(listen, F_GETFL) | O_NONBLOCK);

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
  for (const ModbusConnection& client : impl_->clients)
    ::close(client.fd);
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
    // Wake for the earliest request deadline, if any.
    int wait_ms = -1;
    const auto now = Clock::now();
    for (const ModbusConnection& client : clients) {
      if (client.size == 0) continue;
      const auto left = std::chrono::ceil<std::chrono::milliseconds>(client.deadline - now).count();
      const int left_ms = static_cast<int>(std::clamp<std::int64_t>(left, 0, 60'000));
      wait_ms = wait_ms < 0 ? left_ms : std::min(wait_ms, left_ms);
    }
    fds.clear();
    fds.push_back({wake, POLLIN, 0});
    fds.push_back({listen, POLLIN, 0});
    for (const ModbusConnection& client : clients)
      fds.push_back({client.fd, POLLIN, 0});
    if (::poll(fds.data(), fds.size(), wait_ms) < 0) {
      if (errno == EINTR) continue;
      plc_log()->error("Modbus server stops: {}", system_error("poll"));
      return;
    }
    if (fds[0].revents) return;

    // fds[2 + i] is clients[i]; closing goes from the back so indices hold.
    for (std::size_t i = clients.size(); i-- > 0;) {
      if (!fds[2 + i].revents) continue;
      bool keep = false;
      try {
        keep = receive(clients[i]);
      } catch (const std::exception& e) {  // never let one request end the server
        plc_log()->error("Modbus request failed: {}", e.what());
      }
      if (!keep) drop(i, "hung up, sent garbage or stopped reading");
    }
    const auto checked = Clock::now();
    for (std::size_t i = clients.size(); i-- > 0;)
      if (clients[i].size > 0 && checked >= clients[i].deadline)
        drop(i, "its request did not arrive whole within the request timeout");

    if (fds[1].revents & POLLIN) accept_one();
  }
}

void ModbusServer::Impl::accept_one() {
  sockaddr_in peer{};
  socklen_t peer_size = sizeof peer;
  const int fd = ::accept4(listen, reinterpret_cast<sockaddr*>(&peer), &peer_size,
                           SOCK_CLOEXEC | SOCK_NONBLOCK);
  if (fd < 0) {
    // Out of descriptors, the listening socket stays readable: without
    // a pause the loop would spin a core until one frees up.
    if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS || errno == ENOMEM) {
      plc_log()->error("cannot accept a Modbus connection: {}", std::strerror(errno));
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return;  // or the peer gave up already
  }
  const std::string name = peer_name(peer);
  if (!allowed.empty() && std::ranges::find(allowed, peer.sin_addr.s_addr) == allowed.end()) {
    {
      const std::scoped_lock lock(counters_mutex);
      ++counters.denied;  // counted before the client can see the close
    }
    ::close(fd);
    plc_log()->warn("refused a Modbus connection from {}: not in daemon.modbus_allow", name);
    return;
  }
  const std::scoped_lock lock(counters_mutex);
  if (static_cast<int>(clients.size()) >= options.max_clients) {
    ++counters.rejected;
    ::close(fd);
    plc_log()->warn("refused a Modbus connection from {}: {} clients already connected", name,
                    clients.size());
    return;
  }
  const int one = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  ModbusConnection client;
  client.fd = fd;
  client.peer = name;
  clients.push_back(std::move(client));
  ++counters.connections;
  counters.clients = static_cast<int>(clients.size());
}

void ModbusServer::Impl::drop(std::size_t index, const char* why) {
  plc_log()->debug("dropping the Modbus client {}: {}", clients[index].peer, why);
  const int fd = clients[index].fd;
  clients.erase(clients.begin() + static_cast<std::ptrdiff_t>(index));
  {
    const std::scoped_lock lock(counters_mutex);
    ++counters.dropped;  // counted before the client can see the close
    counters.clients = static_cast<int>(clients.size());
  }
  ::close(fd);
}

bool ModbusServer::Impl::receive(ModbusConnection& client) {
  // Never more than the rest of one frame is buffered: each whole request
  // is answered before the next is read.
  const ssize_t n = ::recv(client.fd, client.buffer.data() + client.size,
                           client.buffer.size() - client.size, MSG_DONTWAIT);
  if (n == 0) return false;  // hung up
  if (n < 0) return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR;
  if (client.size == 0) client.deadline = Clock::now() + options.request_timeout;
  client.size += static_cast<std::size_t>(n);

  while (client.size >= kHeader) {
    const std::uint8_t* header = client.buffer.data();
    const int protocol = (header[2] << 8) | header[3];
    const int length = (header[4] << 8) | header[5];
    if (protocol != 0 || length < kMinLength || length > kMaxLength) {
      plc_log()->debug("Modbus client {}: protocol id {}, length {}: not Modbus TCP", client.peer,
                       protocol, length);
      return false;
    }
    const std::size_t frame = 6 + static_cast<std::size_t>(length);
    if (client.size < frame) return true;  // more to come, by the deadline
    if (!answer(client, header, static_cast<int>(frame))) return false;
    std::memmove(client.buffer.data(), client.buffer.data() + frame, client.size - frame);
    client.size -= frame;
    // The next request began with this read.
    client.deadline = Clock::now() + options.request_timeout;
  }
  return true;
}

bool ModbusServer::Impl::answer(ModbusConnection& client, const std::uint8_t* frame, int length) {
  const std::uint8_t* pdu = frame + kHeader;
  const int pdu_size = length - static_cast<int>(kHeader);
  const int function = pdu[0];
  if (function == 0 || function >= 0x80) {
    plc_log()->debug("Modbus client {}: function code {}: not a request", client.peer, function);
    return false;
  }
  std::vector<std::uint8_t> reply;
  if (!served(function)) {
    reply = capture->reply_exception(ctx, client.fd, frame, MODBUS_EXCEPTION_ILLEGAL_FUNCTION);
  } else if (!pdu_size_right(pdu, pdu_size)) {
    reply = capture->reply_exception(ctx, client.fd, frame, MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
  } else {
    refresh(control.status());
    const bool trigger_before = mapping->tab_bits[modbus_coil::trigger] != 0;
    const bool lights_off_before = mapping->tab_bits[modbus_coil::lights_off] != 0;
    // libmodbus answers from the mapping (reads, coil writes, and exceptions
    // for addresses the map does not have), captured, so the edge acts
    // before the PLC hears its write acknowledged.
    reply = capture->reply(ctx, client.fd, frame, length, mapping);
    act(!trigger_before && mapping->tab_bits[modbus_coil::trigger] != 0,
        !lights_off_before && mapping->tab_bits[modbus_coil::lights_off] != 0);
  }
  {
    const std::scoped_lock lock(counters_mutex);
    ++counters.requests;
  }
  // A reply is at most 260 bytes: a client whose socket cannot take it
  // whole has stopped reading its replies.
  const ssize_t sent = ::send(client.fd, reply.data(), reply.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  return sent == static_cast<ssize_t>(reply.size());
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

  catalogue::ScanErrorCode error = catalogue::ScanErrorCode::none;
  if (refused)
    error = *refused;
  else if (failed)
    error = status.last_error_code == catalogue::ScanErrorCode::none
                ? catalogue::ScanErrorCode::internal
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
      refused = catalogue::ScanErrorCode::lights;
      plc_log()->error("PLC: lights off failed: {}", off.error().describe());
    }
  }
  if (trigger_edge) {
    catalogue::ScanSubmission submission;
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
      refused = control.status().state == DaemonState::stopping ? catalogue::ScanErrorCode::aborted
                : submitted.error().code == ErrorCode::queue_full
                    ? catalogue::ScanErrorCode::queue_full
                    : catalogue::ScanErrorCode::storage;
      plc_log()->warn("PLC: trigger refused: {}", submitted.error().describe());
      const std::scoped_lock lock(counters_mutex);
      ++counters.triggers_refused;
    }
  }
  if (trigger_edge || lights_off_edge) refresh(control.status());
}

}  // namespace psrig::daemon
