// psrigd under clients that never finish their requests: 64 of them, each
// dripping a byte every 100 ms (and reconnecting when closed), the way a
// slowloris attack or a wedged script does. Lights-off and status must still
// answer within a second (the goal), and every request must still
// end: the front closes what does not arrive by its deadline.

#include <algorithm>
#include <atomic>
#include <chrono>
#include <iostream>
#include <poll.h>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "daemon_process.h"
#include "raw_http.h"

namespace psrig::test {
namespace {

using Clock = std::chrono::steady_clock;

// One slow client: sends `head`, then `drip` one byte at a time every
// 100 ms, reconnecting 50 ms after the daemon closes; counts the answers it
// got by status code.
class Dripper {
 public:
  Dripper(int port, std::string head, std::string drip)
      : thread_([this, port, head = std::move(head), drip = std::move(drip)] {
          run(port, head, drip);
        }) {}
  ~Dripper() {
    stop_ = true;
    thread_.join();
  }
  int answers_with(int status) const { return status == 408 ? timeouts_.load() : status == 503 ? busy_.load() : 0; }
  int connections() const { return connections_; }

 private:
  void run(int port, const std::string& head, const std::string& drip) {
    while (!stop_) {
      const int fd = connect_loopback(port);
      if (fd < 0) {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        continue;
      }
      ++connections_;
      bool open = ::send(fd, head.data(), head.size(), MSG_NOSIGNAL) > 0;
      for (std::size_t i = 0; open && !stop_; i = (i + 1) % drip.size()) {
        pollfd entry{fd, POLLIN, 0};
        if (::poll(&entry, 1, 100) > 0) {  // an answer, or closed
          char buffer[512];
          const ssize_t n = ::recv(fd, buffer, sizeof buffer - 1, 0);
          if (n > 0) {
            const int status = status_of(std::string(buffer, static_cast<std::size_t>(n)));
            if (status == 408) ++timeouts_;
            if (status == 503) ++busy_;
          }
          break;
        }
        open = ::send(fd, &drip[i], 1, MSG_NOSIGNAL) == 1;
      }
      ::close(fd);
      std::this_thread::sleep_for(std::chrono::milliseconds(50));  // then tries again
    }
  }

  std::atomic<bool> stop_{false};
  std::atomic<int> timeouts_{0}, busy_{0}, connections_{0};
  std::thread thread_;
};

// The 99th percentile of `count` exchanges of `request`, in ms, each on a
// new connection as curl makes them; every one must answer 200.
double p99_ms(int port, const std::string& request, int count) {
  std::vector<double> ms;
  for (int i = 0; i < count; ++i) {
    const auto start = Clock::now();
    const auto [status, answer] = raw_http(port, request);
    ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    EXPECT_EQ(status, 200) << request << answer;
  }
  std::sort(ms.begin(), ms.end());
  return ms[static_cast<std::size_t>(0.99 * (count - 1))];
}

TEST(Psrigd, SixtyFourSlowClientsDelayNeitherLightsOffNorStatus) {
  TempDir temp;
  const int port = free_port();
  Daemon daemon(daemon_config(temp, port), port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();

  const std::string status = "GET /v1/status HTTP/1.1\r\nHost: x\r\n\r\n";
  const std::string lights_off = "POST /v1/lights/off HTTP/1.1\r\nHost: x\r\n\r\n";  // as curl -X POST
  const std::string search = "GET /v1/scans?limit=5 HTTP/1.1\r\nHost: x\r\n\r\n";
  constexpr int kCount = 100;
  const double status_alone = p99_ms(port, status, kCount);
  const double lights_off_alone = p99_ms(port, lights_off, kCount);
  const double search_alone = p99_ms(port, search, kCount);

  double status_loaded = 0, lights_off_loaded = 0, search_loaded = 0;
  int timeouts = 0, busy = 0, connections = 0;
  {
    // Heads that never end (on every lane's routes), bodies that never end,
    // counted and chunked.
    std::vector<std::unique_ptr<Dripper>> drippers;
    for (int i = 0; i < 64; ++i) {
      const int kind = i % 4;
      if (kind == 0) drippers.push_back(std::make_unique<Dripper>(port, "GET /v1/status HTTP/1.1\r\n", "X-Slow: 1\r\n"));
      if (kind == 1) drippers.push_back(std::make_unique<Dripper>(port, "POST /v1/lights/off HTTP/1.1\r\n", "X-Slow: 1\r\n"));
      if (kind == 2)
        drippers.push_back(std::make_unique<Dripper>(
            port, "POST /v1/scans HTTP/1.1\r\nHost: x\r\nContent-Length: 4000\r\n\r\n", "{ "));
      if (kind == 3)
        drippers.push_back(std::make_unique<Dripper>(
            port, "POST /v1/scans HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n", "1\r\nx\r\n"));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(500));  // all dripping
    status_loaded = p99_ms(port, status, kCount);
    lights_off_loaded = p99_ms(port, lights_off, kCount);
    search_loaded = p99_ms(port, search, kCount);
    // Long enough for the head and request deadlines (2 s, 10 s) to close
    // some of them.
    std::this_thread::sleep_for(std::chrono::milliseconds(std::max<long>(0, 10500 - 3 * kCount)));
    for (const auto& d : drippers) {
      timeouts += d->answers_with(408);
      busy += d->answers_with(503);
      connections += d->connections();
    }
  }
  std::cerr << "p99 with no other client / with 64 dripping: status " << status_alone << " / "
            << status_loaded << " ms, lights-off " << lights_off_alone << " / "
            << lights_off_loaded << " ms, search " << search_alone << " / " << search_loaded
            << " ms; the drippers made " << connections << " connections and got " << timeouts
            << " 408s and " << busy << " 503s\n";
  EXPECT_LT(status_loaded, 1000);
  EXPECT_LT(lights_off_loaded, 1000);
  EXPECT_LT(search_loaded, 1000);
  // Closed by the daemon, every one of them, again and again: at the
  // deadline, or sooner for a newer connection from the same address.
  EXPECT_GE(timeouts + busy, 2 * 64);
  EXPECT_EQ(daemon.get("/v1/status")["state"], "idle");
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

// What a request may not do: take longer than its deadlines or grow past
// the head limit. Each gets a clear answer and a closed connection.
TEST(Psrigd, TheFrontBoundsTimeAndSizeOfEveryRequest) {
  TempDir temp;
  const int port = free_port();
  Daemon daemon(daemon_config(temp, port), port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();

  auto start = Clock::now();
  std::string answer = raw_http_until_closed(port, "GET /v1/status HTTP/1.1\r\nHost: x\r\n");
  auto took = Clock::now() - start;
  EXPECT_TRUE(answer.starts_with("HTTP/1.1 408")) << answer;
  EXPECT_TRUE(contains(body_of(answer), "request head not received within 2 s")) << answer;
  EXPECT_GT(took, std::chrono::milliseconds(1900));
  EXPECT_LT(took, std::chrono::milliseconds(3500));

  // 20 KiB of headers: past the 16 KiB head limit.
  std::string headers;
  for (int i = 0; headers.size() < 20 * 1024; ++i)
    headers += "X-Header-" + std::to_string(i) + ": " + std::string(100, 'v') + "\r\n";
  answer = raw_http_until_closed(port, "GET /v1/status HTTP/1.1\r\n" + headers + "\r\n");
  EXPECT_TRUE(answer.starts_with("HTTP/1.1 431")) << answer.substr(0, 200);
  EXPECT_TRUE(contains(body_of(answer), "larger than 16384 bytes")) << answer;

  // A counted body that stops short: the whole-request deadline (10 s)
  // closes it. Shown with a body the front holds.
  start = Clock::now();
  answer = raw_http_until_closed(
      port, "POST /v1/scans HTTP/1.1\r\nHost: x\r\nContent-Length: 100\r\n\r\n{\"sample_id\"", 15);
  took = Clock::now() - start;
  EXPECT_TRUE(answer.starts_with("HTTP/1.1 408")) << answer;
  EXPECT_TRUE(contains(body_of(answer), "request body not received within 10 s")) << answer;
  EXPECT_GT(took, std::chrono::milliseconds(9500));
  EXPECT_EQ(daemon.get("/v1/scans")["scans"].size(), 0U);  // nothing was queued
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

}  // namespace
}  // namespace psrig::test
