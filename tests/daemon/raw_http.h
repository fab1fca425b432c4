#pragma once
// HTTP to psrigd byte for byte, on raw sockets: for what no client library
// sends (malformed, slow, oversized or smuggled requests).

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sstream>
#include <string>
#include <sys/socket.h>
#include <unistd.h>
#include <utility>

namespace psrig::test {

// A TCP connection to the daemon on loopback whose reads and writes give
// up after `timeout_s` seconds; -1 when it cannot connect.
inline int connect_loopback(int port, int timeout_s = 5) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  timeval timeout{timeout_s, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &timeout, sizeof timeout);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// The status code of an HTTP/1.1 answer, -1 for none.
inline int status_of(const std::string& answer) {
  return answer.starts_with("HTTP/1.1 ") ? std::stoi(answer.substr(9, 3)) : -1;
}

// One raw HTTP exchange, byte for byte as given (no client tidies the path):
// the status code and the whole answer.
inline std::pair<int, std::string> raw_http(int port, const std::string& request) {
  const int fd = connect_loopback(port);
  if (fd < 0) return {-1, ""};
  (void)!::send(fd, request.data(), request.size(), MSG_NOSIGNAL);
  std::string answer;
  char buffer[4096];
  // Until the server closes, or the body its Content-Length announces is in
  // (httplib holds a refused connection open until its read timeout).
  const auto complete = [&] {
    const auto end = answer.find("\r\n\r\n");
    const auto length = answer.find("Content-Length: ");
    if (end == std::string::npos || length == std::string::npos || length > end) return false;
    return answer.size() >= end + 4 + std::stoul(answer.substr(length + 16));
  };
  for (ssize_t n; !complete() && (n = ::recv(fd, buffer, sizeof buffer, 0)) > 0;)
    answer.append(buffer, static_cast<std::size_t>(n));
  ::close(fd);
  return {status_of(answer), answer};
}

// `request` on a raw socket, then everything the server sends until it
// closes the connection (or `timeout_s` seconds pass without a byte).
inline std::string raw_http_until_closed(int port, const std::string& request, int timeout_s = 5) {
  std::string answer;
  const int fd = connect_loopback(port, timeout_s);
  if (fd >= 0) {
    (void)!::send(fd, request.data(), request.size(), MSG_NOSIGNAL);
    char buffer[4096];
    for (ssize_t n; (n = ::recv(fd, buffer, sizeof buffer, 0)) > 0;)
      answer.append(buffer, static_cast<std::size_t>(n));
    ::close(fd);
  }
  return answer;
}

// `request`'s headers, then `total` bytes of body in chunks of `chunk`
// (chunked transfer coding), on a raw socket; stops sending when the server
// closes. The status code (-1 for none) and the whole answer.
inline std::pair<int, std::string> chunked_http(int port, const std::string& request, std::size_t total,
                                         std::size_t chunk) {
  const int fd = connect_loopback(port);
  if (fd < 0) return {-1, ""};
  const auto send_all = [fd](const std::string& data) {
    for (std::size_t sent = 0; sent < data.size();) {
      const ssize_t n = ::send(fd, data.data() + sent, data.size() - sent, MSG_NOSIGNAL);
      if (n <= 0) return false;
      sent += static_cast<std::size_t>(n);
    }
    return true;
  };
  std::ostringstream size;
  size << std::hex << chunk;
  const std::string piece = size.str() + "\r\n" + std::string(chunk, 'x') + "\r\n";
  bool open = send_all(request + "Transfer-Encoding: chunked\r\n\r\n");
  for (std::size_t sent = 0; open && sent < total; sent += chunk)
    open = send_all(piece);
  if (open) send_all("0\r\n\r\n");
  std::string answer;
  char buffer[4096];
  for (ssize_t n; (n = ::recv(fd, buffer, sizeof buffer, 0)) > 0;)
    answer.append(buffer, static_cast<std::size_t>(n));
  ::close(fd);
  return {status_of(answer), answer};
}

inline std::string body_of(const std::string& answer) {
  const auto at = answer.find("\r\n\r\n");
  return at == std::string::npos ? "" : answer.substr(at + 4);
}

}  // namespace psrig::test
