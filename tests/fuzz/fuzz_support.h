#pragma once
// The definitions behind fuzz_target.h, included by exactly one file per
// program (each target's .cpp), so that each target builds from one file.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <system_error>

#include "fuzz_target.h"
#include "psrig/base/log.h"

namespace psrig::fuzz {

namespace {
std::filesystem::path make_scratch() {
  namespace fs = std::filesystem;
  fs::path base = "/dev/shm";
  std::error_code ec;
  if (!fs::is_directory(base, ec) || ::access(base.c_str(), W_OK) != 0) {
    const char* tmp = std::getenv("TMPDIR");
    base = tmp && *tmp ? tmp : "/tmp";
  }
  std::string pattern = (base / "psrig-fuzz-XXXXXX").string();
  if (!::mkdtemp(pattern.data())) {
    std::perror("psrig fuzz: mkdtemp");
    std::abort();
  }
  return pattern;
}
struct Scratch {
  std::filesystem::path path = make_scratch();
  ~Scratch() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};
}  // namespace

std::filesystem::path scratch_directory() {
  static Scratch scratch;
  return scratch.path;
}

void write_file(const std::filesystem::path& file, const std::uint8_t* data, std::size_t size) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  out.close();
  if (!out) {
    std::fprintf(stderr, "psrig fuzz: cannot write %s\n", file.c_str());
    std::abort();
  }
}

void write_file(const std::filesystem::path& file, std::string_view text) {
  write_file(file, reinterpret_cast<const std::uint8_t*>(text.data()), text.size());
}

int free_loopback_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t length = sizeof address;
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) != 0) {
    std::perror("psrig fuzz: free port");
    std::abort();
  }
  ::close(fd);
  return ntohs(address.sin_port);
}

std::string exchange(int port, const std::uint8_t* data, std::size_t size, int deadline_ms,
                     int answer_window_ms, std::string_view stop_after) {
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::milliseconds(deadline_ms);
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    std::perror("psrig fuzz: socket");
    std::abort();
  }
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  int connected = ::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address);
  if (connected != 0 && errno == EINTR) {
    // A signal (libFuzzer's own timer) interrupted it; the connection goes
    // on by itself: wait for it and take its outcome.
    pollfd p{fd, POLLOUT, 0};
    while (::poll(&p, 1, 5000) < 0 && errno == EINTR) {
    }
    int error = 0;
    socklen_t length = sizeof error;
    if (::getsockopt(fd, SOL_SOCKET, SO_ERROR, &error, &length) == 0 && error == 0 &&
        (p.revents & POLLOUT))
      connected = 0;
    else
      errno = error != 0 ? error : ETIMEDOUT;
  }
  if (connected != 0) {
    // The server is gone (it should never go while the target runs).
    std::perror("psrig fuzz: connect");
    std::abort();
  }
  const auto remaining = [&] {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
    return static_cast<int>(std::max<long long>(0, left.count()));
  };
  // The server may close early (a refused request): then the rest does not go.
  std::size_t sent = 0;
  while (sent < size && remaining() > 0) {
    pollfd p{fd, POLLOUT, 0};
    if (::poll(&p, 1, remaining()) <= 0) break;
    const ssize_t n = ::send(fd, data + sent, size - sent, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n <= 0) {
      if (n < 0 && (errno == EAGAIN || errno == EINTR)) continue;
      break;
    }
    sent += static_cast<std::size_t>(n);
  }
  // With a window: wait that long for the first byte of an answer before
  // shutting the writing side (a server that refuses to write to a
  // half-closed peer, as httplib does, answers a whole request in time).
  if (answer_window_ms > 0) {
    pollfd p{fd, POLLIN, 0};
    ::poll(&p, 1, std::min(answer_window_ms, remaining()));
  }
  ::shutdown(fd, SHUT_WR);
  std::string answer;
  char buffer[4096];
  while (remaining() > 0) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, remaining()) <= 0) break;
    const ssize_t n = ::recv(fd, buffer, sizeof buffer, MSG_DONTWAIT);
    if (n < 0 && (errno == EAGAIN || errno == EINTR)) continue;
    if (n <= 0) break;
    answer.append(buffer, static_cast<std::size_t>(n));
    if (!stop_after.empty()) {
      const auto head_end = answer.find("\r\n\r\n");
      if (head_end != std::string::npos && answer.substr(0, head_end).find(stop_after) != std::string::npos)
        break;
    }
  }
  static const bool verbose = std::getenv("PSRIG_FUZZ_VERBOSE") != nullptr;
  if (verbose) {
    std::string shown = answer.substr(0, std::min<std::size_t>(answer.size(), 60));
    for (char& c : shown)
      if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7F) c = '.';
    std::fprintf(stderr, "exchange: %zu bytes sent of %zu, %zu bytes back: %s\n", sent, size,
                 answer.size(), shown.c_str());
  }
  const linger reset{1, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_LINGER, &reset, sizeof reset);
  ::close(fd);
  return answer;
}

void quiet_logs() {
  set_log_level(spdlog::level::off);
}

}  // namespace psrig::fuzz
