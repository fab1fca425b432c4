#include "request_stream.h"

#include <algorithm>
#include <arpa/inet.h>
#include <cerrno>
#include <cstring>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>

namespace psrig::daemon {

RequestStream::RequestStream(int fd, std::string already_read, Clock::time_point read_deadline,
                             std::chrono::milliseconds write_timeout)
    : fd_(fd),
      already_read_(std::move(already_read)),
      read_deadline_(read_deadline),
      write_timeout_(write_timeout) {}

bool RequestStream::wait_for(short events, Clock::time_point until) const {
  for (;;) {
    const auto left = std::chrono::ceil<std::chrono::milliseconds>(until - Clock::now()).count();
    if (left <= 0) return false;
    pollfd entry{fd_, events, 0};
    const int ready = ::poll(&entry, 1, static_cast<int>(std::min<long long>(left, 1000 * 60)));
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) return false;
    // A peer that has gone is "readable" (the read says so) but not writable.
    if (events == POLLOUT) return (entry.revents & POLLOUT) && !(entry.revents & (POLLERR | POLLHUP));
    return true;
  }
}

bool RequestStream::is_readable() const {
  return taken_ < already_read_.size() || wait_for(POLLIN, read_deadline_);
}

bool RequestStream::is_writable() const {
  return wait_for(POLLOUT, Clock::now() + write_timeout_);
}

ssize_t RequestStream::read(char* ptr, size_t size) {
  if (taken_ < already_read_.size()) {
    const std::size_t n = std::min(size, already_read_.size() - taken_);
    std::memcpy(ptr, already_read_.data() + taken_, n);
    taken_ += n;
    return static_cast<ssize_t>(n);
  }
  for (;;) {
    const ssize_t n = ::recv(fd_, ptr, size, MSG_DONTWAIT);
    if (n >= 0) return n;
    if (errno == EINTR) continue;
    if (errno != EAGAIN && errno != EWOULDBLOCK) return -1;
    if (!wait_for(POLLIN, read_deadline_)) return -1;
  }
}

ssize_t RequestStream::write(const char* ptr, size_t size) {
  const auto until = Clock::now() + write_timeout_;
  for (;;) {
    const ssize_t n = ::send(fd_, ptr, size, MSG_DONTWAIT | MSG_NOSIGNAL);
    if (n >= 0) return n;
    if (errno == EINTR) continue;
    if (errno != EAGAIN && errno != EWOULDBLOCK) return -1;
    if (!wait_for(POLLOUT, until)) return -1;
  }
}

void socket_address(int fd, bool remote, std::string& ip, int& port) {
  sockaddr_storage address{};
  socklen_t length = sizeof address;
  auto* any = reinterpret_cast<sockaddr*>(&address);
  if ((remote ? ::getpeername(fd, any, &length) : ::getsockname(fd, any, &length)) != 0) return;
  char text[INET6_ADDRSTRLEN] = {};
  if (address.ss_family == AF_INET) {
    const auto* v4 = reinterpret_cast<const sockaddr_in*>(&address);
    ::inet_ntop(AF_INET, &v4->sin_addr, text, sizeof text);
    port = ntohs(v4->sin_port);
  } else if (address.ss_family == AF_INET6) {
    const auto* v6 = reinterpret_cast<const sockaddr_in6*>(&address);
    ::inet_ntop(AF_INET6, &v6->sin6_addr, text, sizeof text);
    port = ntohs(v6->sin6_port);
  }
  ip = text;
}

void RequestStream::get_remote_ip_and_port(std::string& ip, int& port) const {
  socket_address(fd_, true, ip, port);
}

void RequestStream::get_local_ip_and_port(std::string& ip, int& port) const {
  socket_address(fd_, false, ip, port);
}

}  // namespace psrig::daemon
