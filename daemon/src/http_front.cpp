#include "http_front.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <fcntl.h>
#include <map>
#include <nlohmann/json.hpp>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include "psrig/base/log.h"
#include "request_stream.h"

namespace psrig::daemon {
namespace {

using Clock = std::chrono::steady_clock;

bool iequals(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) ==
                  std::tolower(static_cast<unsigned char>(y));
         });
}

std::string_view trim(std::string_view text) {
  while (!text.empty() && (text.front() == ' ' || text.front() == '\t')) text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\t')) text.remove_suffix(1);
  return text;
}

// What the front needs of a request head: where the request goes and how
// much body follows it.
struct HeadSummary {
  std::string_view method;
  std::string_view path;
  std::optional<std::size_t> content_length;  // nullopt: none, or not a number
  bool has_content_length = false;
  bool has_transfer_encoding = false;
  bool expects_continue = false;
};

HeadSummary summarise(std::string_view head) {
  HeadSummary summary;
  const auto line_end = head.find("\r\n");
  const std::string_view line = head.substr(0, line_end);
  const auto first_space = line.find(' ');
  summary.method = line.substr(0, first_space);
  if (first_space != std::string_view::npos) {
    std::string_view target = line.substr(first_space + 1);
    target = target.substr(0, target.find(' '));
    summary.path = target.substr(0, target.find('?'));
  }
  for (auto at = line_end; at != std::string_view::npos && at + 2 < head.size();) {
    const auto next = head.find("\r\n", at + 2);
    const std::string_view field = head.substr(at + 2, next - (at + 2));
    at = next;
    const auto colon = field.find(':');
    if (colon == std::string_view::npos) continue;
    const std::string_view name = field.substr(0, colon);
    const std::string_view value = trim(field.substr(colon + 1));
    if (iequals(name, "Content-Length")) {
      summary.has_content_length = true;
      std::size_t length = 0;
      const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), length);
      if (ec == std::errc() && end == value.data() + value.size()) summary.content_length = length;
    } else if (iequals(name, "Transfer-Encoding")) {
      summary.has_transfer_encoding = true;
    } else if (iequals(name, "Expect")) {
      summary.expects_continue = iequals(value, "100-continue");
    }
  }
  return summary;
}

}  // namespace

struct HttpFront::Waiting {
  int fd = -1;  // -1 once sent on or closed
  std::string peer;
  std::string bytes;
  std::size_t head_end = std::string::npos;  // where "\r\n\r\n" starts, once in
  Clock::time_point accepted;
};

std::string closing_answer(int status, std::string_view reason, std::string_view message) {
  const std::string body =
      nlohmann::json{{"error", message}}.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) +
      "\n";
  return "HTTP/1.1 " + std::to_string(status) + " " + std::string(reason) +
         "\r\nContent-Type: application/json\r\nContent-Length: " + std::to_string(body.size()) +
         "\r\nConnection: close\r\n\r\n" + body;
}

void answer_and_close(int fd, const std::string& answer) {
  (void)!::send(fd, answer.data(), answer.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
  ::shutdown(fd, SHUT_WR);
  char sink[4096];
  for (std::size_t drained = 0; drained < 64 * 1024;) {
    const ssize_t n = ::recv(fd, sink, sizeof sink, MSG_DONTWAIT);
    if (n <= 0) break;
    drained += static_cast<std::size_t>(n);
  }
  ::close(fd);
}

HttpFront::HttpFront(FrontLimits limits, IsSafety is_safety, Receive receive)
    : limits_(limits), is_safety_(std::move(is_safety)), receive_(std::move(receive)) {
  wake_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  thread_ = std::thread([this] { run(); });
}

HttpFront::~HttpFront() {
  stop();
  if (wake_fd_ >= 0) ::close(wake_fd_);
}

void HttpFront::wake() {
  const std::uint64_t one = 1;
  (void)!::write(wake_fd_, &one, sizeof one);
}

void HttpFront::add(int fd) {
  {
    std::lock_guard lock(inbox_mutex_);
    if (stopping_) {
      ::close(fd);
      return;
    }
    inbox_.push_back(fd);
  }
  wake();
}

void HttpFront::stop() {
  {
    std::lock_guard lock(inbox_mutex_);
    stopping_ = true;
  }
  wake();
  if (thread_.joinable()) thread_.join();
}

std::optional<Lane> HttpFront::ready_lane(const Waiting& w) const {
  if (w.head_end == std::string::npos) return std::nullopt;
  const HeadSummary head = summarise(std::string_view(w.bytes).substr(0, w.head_end + 2));
  const Lane lane = is_safety_(head.method, head.path) ? Lane::safety : Lane::general;
  const std::string_view body = std::string_view(w.bytes).substr(w.head_end + 4);
  // The client sends its body only after "100 Continue", which httplib
  // answers: on at once, to a general thread that reads the body under the
  // request deadline.
  if (head.expects_continue) return Lane::general;
  // A body too large to hold here goes the same way, as does a length
  // httplib is to refuse.
  if (head.has_content_length &&
      (!head.content_length || *head.content_length > limits_.max_waiting_body))
    return Lane::general;
  if (head.has_transfer_encoding) {
    // Chunked: held until its last chunk ("0" line, blank line) is in, or
    // until there is no more room, when httplib's reader takes over.
    const auto last_chunk = body.starts_with("0\r\n") ? 0 : body.find("\r\n0\r\n");
    const bool ended =
        last_chunk != body.npos && body.find("\r\n\r\n", last_chunk + 1) != body.npos;
    if (ended || w.bytes.size() >= limits_.max_head_bytes + limits_.max_waiting_body) return lane;
    return std::nullopt;
  }
  if (body.size() < head.content_length.value_or(0)) return std::nullopt;
  return lane;
}

bool HttpFront::read_some(Waiting& w) {
  const std::size_t cap = limits_.max_head_bytes + limits_.max_waiting_body;
  bool closed = false;
  while (w.bytes.size() < cap) {
    char buffer[4096];
    const ssize_t n =
        ::recv(w.fd, buffer, std::min(sizeof buffer, cap - w.bytes.size()), MSG_DONTWAIT);
    if (n > 0) {
      const std::size_t searched_to = w.bytes.size();
      w.bytes.append(buffer, static_cast<std::size_t>(n));
      if (w.head_end == std::string::npos) {
        const auto at = w.bytes.find("\r\n\r\n", searched_to < 3 ? 0 : searched_to - 3);
        if (at != std::string::npos) w.head_end = at;
      }
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    closed = n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK);
    break;
  }
  const bool head_too_large = w.head_end == std::string::npos
                                  ? w.bytes.size() >= limits_.max_head_bytes
                                  : w.head_end + 4 > limits_.max_head_bytes;
  if (head_too_large) {
    const auto line_end = w.bytes.find("\r\n");
    answer_and_close(w.fd, line_end == std::string::npos || line_end >= limits_.max_head_bytes
                               ? closing_answer(414, "URI Too Long", "request URI too long")
                               : closing_answer(431, "Request Header Fields Too Large",
                                                "request head larger than " +
                                                    std::to_string(limits_.max_head_bytes) + " bytes"));
    w.fd = -1;
    return true;
  }
  if (const auto lane = ready_lane(w)) {
    receive_({w.fd, w.peer, std::move(w.bytes), *lane, w.accepted});
    w.fd = -1;
    return true;
  }
  if (closed) {  // gone before its request was in
    ::close(w.fd);
    w.fd = -1;
    return true;
  }
  return false;
}

void HttpFront::evict_for(const std::string& peer) {
  std::map<std::string, std::size_t> per_peer;
  for (const auto& w : waiting_)
    if (w.fd >= 0) ++per_peer[w.peer];
  std::string victim_peer;
  if (per_peer[peer] >= limits_.max_waiting_per_peer) {
    victim_peer = peer;
  } else {
    std::size_t total = 0;
    for (const auto& [address, count] : per_peer) total += count;
    if (total < limits_.max_waiting) return;
    victim_peer = std::max_element(per_peer.begin(), per_peer.end(), [](const auto& a, const auto& b) {
                    return a.second < b.second;
                  })->first;
  }
  // waiting_ is in order of arrival: the first of that peer is its oldest.
  for (auto& w : waiting_) {
    if (w.fd < 0 || w.peer != victim_peer) continue;
    answer_and_close(w.fd, closing_answer(503, "Service Unavailable",
                                          "too many unfinished requests from " + victim_peer +
                                              "; the oldest was closed"));
    w.fd = -1;
    return;
  }
}

void HttpFront::admit(int fd) {
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK);
  Waiting w;
  w.fd = fd;
  w.accepted = Clock::now();
  int port = 0;
  socket_address(fd, true, w.peer, port);
  // Most requests are in by now: they never take a slot.
  if (read_some(w)) return;
  evict_for(w.peer);
  waiting_.push_back(std::move(w));
}

void HttpFront::run() {
  std::vector<pollfd> polled;
  for (;;) {
    polled.clear();
    polled.push_back({wake_fd_, POLLIN, 0});
    auto next_deadline = Clock::now() + std::chrono::seconds(1);
    for (const auto& w : waiting_) {
      polled.push_back({w.fd, POLLIN, 0});
      const auto deadline = w.accepted + (w.head_end == std::string::npos
                                              ? limits_.head_deadline
                                              : limits_.request_deadline);
      next_deadline = std::min(next_deadline, deadline);
    }
    const auto wait =
        std::chrono::ceil<std::chrono::milliseconds>(next_deadline - Clock::now()).count();
    if (::poll(polled.data(), polled.size(), static_cast<int>(std::max<long long>(0, wait))) < 0 &&
        errno != EINTR) {
      logger("http")->error("HTTP front: poll failed: {}", std::strerror(errno));
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    const std::size_t polled_waiting = polled.size() - 1;
    for (std::size_t i = 0; i < polled_waiting; ++i)
      if (polled[i + 1].revents != 0 && waiting_[i].fd >= 0) read_some(waiting_[i]);
    const auto now = Clock::now();
    for (auto& w : waiting_) {
      if (w.fd < 0) continue;
      const bool head_in = w.head_end != std::string::npos;
      if (now < w.accepted + (head_in ? limits_.request_deadline : limits_.head_deadline)) continue;
      const auto seconds = [](std::chrono::milliseconds d) {
        return fmt::format("{:g} s", static_cast<double>(d.count()) / 1000.0);
      };
      answer_and_close(w.fd, closing_answer(408, "Request Timeout",
                                            head_in ? "request body not received within " +
                                                          seconds(limits_.request_deadline)
                                                    : "request head not received within " +
                                                          seconds(limits_.head_deadline)));
      w.fd = -1;
    }
    if (polled[0].revents != 0) {
      std::uint64_t count = 0;
      (void)!::read(wake_fd_, &count, sizeof count);
      std::vector<int> arrived;
      bool stop_now = false;
      {
        std::lock_guard lock(inbox_mutex_);
        arrived.swap(inbox_);
        stop_now = stopping_;
      }
      if (stop_now) {
        for (int fd : arrived) ::close(fd);
        for (auto& w : waiting_)
          if (w.fd >= 0) ::close(w.fd);
        waiting_.clear();
        return;
      }
      for (int fd : arrived) {
        std::erase_if(waiting_, [](const Waiting& w) { return w.fd < 0; });
        admit(fd);
      }
    }
    std::erase_if(waiting_, [](const Waiting& w) { return w.fd < 0; });
  }
}

}  // namespace psrig::daemon
