#pragma once
// psrigd's HTTP front: one thread, one poll() over every connection still
// sending its request. A connection costs a worker thread only once its
// request head is in (and its body, when small and counted): a client that
// sends a byte every few seconds, or never finishes, holds nothing but a
// slot here, and loses that at the head deadline. Slots are capped per
// address and in total; a new connection that finds them full takes the
// slot of the oldest unfinished one (a real client finishes its head in
// milliseconds; the oldest unfinished one is the slowest), so newcomers
// always get their turn. Each finished request goes to a lane: the safety
// lane (lights off, status) has threads of its own, so it never waits
// behind the others.

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace psrig::daemon {

struct FrontLimits {
  std::chrono::milliseconds head_deadline{2000};     // accept -> request head in
  std::chrono::milliseconds request_deadline{10000};  // accept -> whole request read
  std::size_t max_head_bytes = 16 * 1024;             // 431 (or 414) past it
  std::size_t max_waiting_body = 16 * 1024;  // bodies up to this are read here
  std::size_t max_waiting = 256;             // connections sending their request, in all
  std::size_t max_waiting_per_peer = 32;     // ... from one address
};

enum class Lane { safety, general };

// A request whose head (and, when waited for, body) has arrived.
struct ArrivedRequest {
  int fd = -1;                // non-blocking; the receiver closes it
  std::string peer;           // the client's address
  std::string already_read;   // the bytes read so far, from the start
  Lane lane = Lane::general;
  std::chrono::steady_clock::time_point accepted;
};

class HttpFront {
 public:
  using IsSafety = std::function<bool(std::string_view method, std::string_view path)>;
  using Receive = std::function<void(ArrivedRequest)>;
  // Starts the front's thread; `receive` runs on it and must not block.
  HttpFront(FrontLimits limits, IsSafety is_safety, Receive receive);
  ~HttpFront();
  HttpFront(const HttpFront&) = delete;
  HttpFront& operator=(const HttpFront&) = delete;

  // Takes a just-accepted connection (any thread).
  void add(int fd);
  // Closes every waiting connection and ends the thread. Idempotent.
  void stop();

  const FrontLimits& limits() const { return limits_; }

 private:
  struct Waiting;
  void run();
  void admit(int fd);
  // Reads what has come; whether `w` is finished with (sent on or closed).
  bool read_some(Waiting& w);
  // Where the request in `w` is complete enough to send on, its lane.
  std::optional<Lane> ready_lane(const Waiting& w) const;
  void evict_for(const std::string& peer);
  void wake();

  const FrontLimits limits_;
  const IsSafety is_safety_;
  const Receive receive_;
  int wake_fd_ = -1;
  std::mutex inbox_mutex_;
  std::vector<int> inbox_;
  bool stopping_ = false;
  std::vector<Waiting> waiting_;  // the front thread's alone
  std::thread thread_;
};

// A whole HTTP answer with a JSON {"error": message} body that closes the
// connection, for answering where httplib never sees the request.
[[nodiscard]] std::string closing_answer(int status, std::string_view reason,
                                         std::string_view message);
// Sends `answer` as far as the socket takes it now, drains what the client
// sent (so the close is not a reset that loses the answer), and closes.
void answer_and_close(int fd, const std::string& answer);

}  // namespace psrig::daemon
