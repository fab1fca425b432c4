#pragma once
// The connection a request arrived on, as httplib reads and writes it: the
// bytes the front already read come first, then the socket's. Every read
// gives up at the request's deadline, however slowly bytes keep coming
// (httplib's own stream waits its read timeout per byte); every write gives
// up after the write timeout.

#include <chrono>
#include <httplib.h>
#include <string>

namespace psrig::daemon {

class RequestStream final : public httplib::Stream {
 public:
  using Clock = std::chrono::steady_clock;
  // `fd` non-blocking, not owned; `already_read` the front's bytes.
  RequestStream(int fd, std::string already_read, Clock::time_point read_deadline,
                std::chrono::milliseconds write_timeout);

  bool is_readable() const override;
  bool is_writable() const override;
  ssize_t read(char* ptr, size_t size) override;
  ssize_t write(const char* ptr, size_t size) override;
  void get_remote_ip_and_port(std::string& ip, int& port) const override;
  void get_local_ip_and_port(std::string& ip, int& port) const override;
  socket_t socket() const override { return fd_; }

 private:
  // Waits for `events` on the socket until `until`; whether they came.
  bool wait_for(short events, Clock::time_point until) const;

  int fd_;
  std::string already_read_;
  std::size_t taken_ = 0;
  Clock::time_point read_deadline_;
  std::chrono::milliseconds write_timeout_;
};

// The numeric address and port of a socket's peer (`remote`) or its own end.
void socket_address(int fd, bool remote, std::string& ip, int& port);

}  // namespace psrig::daemon
