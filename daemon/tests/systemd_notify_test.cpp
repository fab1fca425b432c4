// The notify protocol as systemd sees it: a datagram socket standing in
// for the service manager's, named by NOTIFY_SOCKET; WATCHDOG_USEC and
// WATCHDOG_PID as systemd sets them for a unit with WatchdogSec=.

#include "psrig/daemon/systemd_notify.h"

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <sys/socket.h>
#include <sys/un.h>
#include <thread>
#include <unistd.h>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace psrig::daemon {
namespace {

using std::chrono::microseconds;
using std::chrono::milliseconds;

class SystemdNotifyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char pattern[] = "/tmp/psrig-notify-XXXXXX";
    ASSERT_NE(::mkdtemp(pattern), nullptr);
    dir_ = pattern;
    path_ = dir_ / "notify.sock";
    socket_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    ASSERT_GE(socket_, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    ASSERT_LT(path_.native().size(), sizeof address.sun_path);
    path_.native().copy(address.sun_path, path_.native().size());
    ASSERT_EQ(::bind(socket_, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
    const timeval timeout{2, 0};
    ::setsockopt(socket_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
    ::setenv("NOTIFY_SOCKET", path_.c_str(), 1);
    ::unsetenv("WATCHDOG_USEC");
    ::unsetenv("WATCHDOG_PID");
  }
  void TearDown() override {
    ::unsetenv("NOTIFY_SOCKET");
    ::unsetenv("WATCHDOG_USEC");
    ::unsetenv("WATCHDOG_PID");
    if (socket_ >= 0) ::close(socket_);
    std::filesystem::remove_all(dir_);
  }

  // The next datagram, or "" after two seconds.
  std::string receive() {
    char buffer[4096];
    const ssize_t n = ::recv(socket_, buffer, sizeof buffer, 0);
    return n > 0 ? std::string(buffer, static_cast<std::size_t>(n)) : std::string();
  }
  // Whether a datagram is waiting now.
  bool pending() {
    char buffer[16];
    return ::recv(socket_, buffer, sizeof buffer, MSG_DONTWAIT | MSG_PEEK) >= 0;
  }

  std::filesystem::path dir_;
  std::filesystem::path path_;
  int socket_ = -1;
  SystemdNotifier notifier_;
};

TEST_F(SystemdNotifyTest, SendsTheProtocolsAssignments) {
  EXPECT_TRUE(notifier_.enabled());
  ASSERT_TRUE(notifier_.ready().has_value());
  EXPECT_EQ(receive(), "READY=1");
  ASSERT_TRUE(notifier_.status("idle, 3 scans done").has_value());
  EXPECT_EQ(receive(), "STATUS=idle, 3 scans done");
  ASSERT_TRUE(notifier_.watchdog().has_value());
  EXPECT_EQ(receive(), "WATCHDOG=1");
  ASSERT_TRUE(notifier_.reloading().has_value());
  EXPECT_EQ(receive(), "RELOADING=1");
  ASSERT_TRUE(notifier_.stopping().has_value());
  EXPECT_EQ(receive(), "STOPPING=1");
  EXPECT_FALSE(pending());
}

TEST_F(SystemdNotifyTest, StatusIsKeptToOneLine) {
  ASSERT_TRUE(notifier_.status("error: camera\ntimeout\r\nREADY=1").has_value());
  EXPECT_EQ(receive(), "STATUS=error: camera timeout  READY=1");
}

TEST_F(SystemdNotifyTest, WithoutNotifySocketEveryCallIsANoOp) {
  ::unsetenv("NOTIFY_SOCKET");
  EXPECT_FALSE(notifier_.enabled());
  EXPECT_TRUE(notifier_.ready().has_value());
  EXPECT_TRUE(notifier_.status("idle").has_value());
  EXPECT_TRUE(notifier_.watchdog().has_value());
  EXPECT_TRUE(notifier_.stopping().has_value());
  EXPECT_FALSE(pending());
}

TEST_F(SystemdNotifyTest, AnUnusableSocketIsAnError) {
  ::setenv("NOTIFY_SOCKET", (dir_ / "nobody-listens.sock").c_str(), 1);
  const auto sent = notifier_.ready();
  ASSERT_FALSE(sent.has_value());
  EXPECT_THAT(sent.error().message, ::testing::HasSubstr("nobody-listens.sock"));
}

TEST_F(SystemdNotifyTest, WatchdogIntervalIsHalfOfWatchdogSec) {
  EXPECT_EQ(notifier_.watchdog_timeout(), std::nullopt);
  EXPECT_EQ(notifier_.watchdog_interval(), std::nullopt);
  ::setenv("WATCHDOG_USEC", "30000000", 1);  // WatchdogSec=30
  EXPECT_EQ(notifier_.watchdog_timeout(), microseconds(30'000'000));
  EXPECT_EQ(notifier_.watchdog_interval(), microseconds(15'000'000));
  ::setenv("WATCHDOG_PID", std::to_string(::getpid()).c_str(), 1);
  EXPECT_EQ(notifier_.watchdog_interval(), microseconds(15'000'000));
  // Meant for another process (a parent that forked us): not ours to pet.
  ::setenv("WATCHDOG_PID", std::to_string(::getpid() + 1).c_str(), 1);
  EXPECT_EQ(notifier_.watchdog_interval(), std::nullopt);
  ::setenv("WATCHDOG_PID", std::to_string(::getpid()).c_str(), 1);
  ::setenv("WATCHDOG_USEC", "not a number", 1);
  EXPECT_EQ(notifier_.watchdog_interval(), std::nullopt);
}

TEST_F(SystemdNotifyTest, PetterPetsAtHalfTheIntervalWhileHealthy) {
  ::setenv("WATCHDOG_USEC", "100000", 1);  // 100 ms: a ping every 50 ms
  std::atomic<bool> healthy = true;
  WatchdogPetter petter(notifier_, [&] { return healthy.load(); });
  ASSERT_TRUE(petter.running());
  const auto began = std::chrono::steady_clock::now();
  for (int i = 0; i < 3; ++i)
    EXPECT_EQ(receive(), "WATCHDOG=1");
  EXPECT_LT(std::chrono::steady_clock::now() - began, milliseconds(1000));

  healthy = false;
  std::this_thread::sleep_for(milliseconds(120));
  while (pending())
    receive();  // pings already on their way
  std::this_thread::sleep_for(milliseconds(200));
  EXPECT_FALSE(pending());

  const auto stopping = std::chrono::steady_clock::now();
  petter.stop();
  EXPECT_FALSE(petter.running());
  EXPECT_LT(std::chrono::steady_clock::now() - stopping, milliseconds(200));
}

TEST_F(SystemdNotifyTest, PetterIdlesWithoutAWatchdog) {
  WatchdogPetter petter(notifier_);
  EXPECT_FALSE(petter.running());
  ::setenv("WATCHDOG_USEC", "100000", 1);
  ::unsetenv("NOTIFY_SOCKET");
  WatchdogPetter unmanaged(notifier_);
  EXPECT_FALSE(unmanaged.running());
}

}  // namespace
}  // namespace psrig::daemon
