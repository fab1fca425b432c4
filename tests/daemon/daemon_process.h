#pragma once
// A real psrigd process for the daemon's tests: its configuration (config/sim.toml
// at 160x120, storage in a temp directory, on a free port), start, readiness,
// signals and exit code, and an HTTP client to it. Optionally the daemon runs
// in its own mount namespace with a tmpfs of a chosen size over a directory
// (its storage root), so a test can fill "the disk" and nothing stays mounted
// when the daemon dies, however the test ends.

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <httplib.h>
#include <iterator>
#include <netinet/in.h>
#include <optional>
#include <sched.h>
#include <signal.h>
#include <spawn.h>
#include <string>
#include <sys/mount.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.h"

namespace psrig::test {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace std::chrono_literals;
using Edits = std::vector<std::pair<std::string, std::string>>;

inline const std::string kToken = "test-token-0123456789abcdef";

// A port nobody listens on now (the kernel's pick, released at once).
inline int free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address);
  socklen_t length = sizeof address;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length);
  ::close(fd);
  return ntohs(address.sin_port);
}

// config/sim.toml at 160x120, scans into `temp`/scans, on `port`.
inline fs::path daemon_config(const TempDir& temp, int port, const Edits& edits = {}) {
  std::string text = file_contents(fs::path(PSRIG_SOURCE_DIR) / "config/sim.toml");
  const auto replace = [&](const std::string& from, const std::string& to) {
    const auto at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at, from.size(), to);
  };
  replace("width = 640", "width = 160");
  replace("height = 480", "height = 120");
  replace("root = \"../out/scans\"", "root = \"scans\"");
  replace("port = 8470", "port = " + std::to_string(port));
  for (const auto& [from, to] : edits)
    replace(from, to);
  const fs::path file = temp / "rig.toml";
  std::ofstream(file) << text;
  return file;
}

// A tmpfs over `at` (an existing directory), seen only by the daemon.
struct PrivateTmpfs {
  fs::path at;
  std::string options;  // mount(8)'s -o, e.g. "size=4m"
};

// Exit code of a child that could not set its private tmpfs up.
inline constexpr int kTmpfsFailed = 97;

// In a forked child (only async-signal-safe calls): a mount namespace of its
// own, nothing propagating back, and the tmpfs. errno on failure, else 0.
inline int mount_private_tmpfs(const char* at, const char* options) {
  if (::unshare(CLONE_NEWNS) != 0) return errno;
  if (::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0) return errno;
  if (::mount("psrig-test", at, "tmpfs", MS_NOSUID | MS_NODEV, options) != 0) return errno;
  return 0;
}

// Why this machine cannot give a test a private tmpfs (no CAP_SYS_ADMIN, a
// seccomp filter), tried in a throwaway child; nothing when it can.
inline std::optional<std::string> private_tmpfs_unavailable(const fs::path& scratch) {
  int pipe_fds[2];
  if (::pipe2(pipe_fds, O_CLOEXEC) != 0) return std::string("pipe: ") + std::strerror(errno);
  const std::string at = scratch.string();
  const pid_t child = ::fork();
  if (child == 0) {
    const int error = mount_private_tmpfs(at.c_str(), "size=64k");
    (void)!::write(pipe_fds[1], &error, sizeof error);
    ::_exit(0);
  }
  ::close(pipe_fds[1]);
  int error = -1;
  if (child < 0 || ::read(pipe_fds[0], &error, sizeof error) != sizeof error) error = ECHILD;
  ::close(pipe_fds[0]);
  if (child > 0) ::waitpid(child, nullptr, 0);
  if (error == 0) return std::nullopt;
  return "cannot mount a tmpfs in a private mount namespace on " + at + ": " +
         std::strerror(error) + " (needs CAP_SYS_ADMIN, e.g. root outside a restricted container)";
}

// The edit that puts config/sim.toml's LEDs on a simulated Modbus LED driver
// the test holds (its switch log shows every LED on and off), with `extra`
// keys for the driver's table (e.g. ", retries = 0").
inline std::pair<std::string, std::string> modbus_lights(int driver_port,
                                                         const std::string& extra = "") {
  return {"backend = \"sim\"\nchannels",
          "backend = \"modbus\"\nmodbus = { host = \"127.0.0.1\", port = " +
              std::to_string(driver_port) + extra + " }\nchannels"};
}

// A psrigd process, killed if the test leaves it running.
class Daemon {
 public:
  Daemon(const fs::path& config, int port, const fs::path& log,
         const std::optional<PrivateTmpfs>& tmpfs = std::nullopt)
      : port_(port), log_(log), client_("127.0.0.1", port) {
    const ProgramCommand command("psrigd", {"--config", config.string()});
    if (tmpfs) {
      spawn_with_tmpfs(command, *tmpfs);
    } else {
      posix_spawn_file_actions_t actions;
      posix_spawn_file_actions_init(&actions);
      posix_spawn_file_actions_addopen(&actions, 2, log.c_str(), O_WRONLY | O_CREAT | O_APPEND,
                                       0644);
      if (posix_spawn(&pid_, command.file().c_str(), &actions, nullptr, command.argv(), environ) !=
          0)
        pid_ = 0;
      posix_spawn_file_actions_destroy(&actions);
    }
    client_.set_connection_timeout(1s);
    client_.set_read_timeout(10s);
    client_.set_bearer_token_auth(kToken.c_str());  // ignored where no token is set
  }
  ~Daemon() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  // Serving, or gone (then the exit code).
  [[nodiscard]] bool wait_ready() {
    const auto deadline = std::chrono::steady_clock::now() + 15s;
    while (std::chrono::steady_clock::now() < deadline) {
      if (exited()) return false;
      if (auto res = client_.Get("/v1/status"); res && res->status == 200) {
        const auto body = json::parse(res->body);
        if (body["state"] != "starting") return true;
      }
      std::this_thread::sleep_for(20ms);
    }
    return false;
  }
  bool exited() {
    if (pid_ <= 0) return true;
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) != pid_) return false;
    exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    pid_ = 0;
    return true;
  }
  // Sends `signal` and waits (at most 20 s) for the exit code.
  int signal_and_wait(int signal) {
    ::kill(pid_, signal);
    const auto deadline = std::chrono::steady_clock::now() + 20s;
    while (!exited() && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(10ms);
    return pid_ == 0 ? exit_code_ : -1;
  }
  [[nodiscard]] int exit_code() const { return exit_code_; }
  [[nodiscard]] pid_t pid() const { return pid_; }
  [[nodiscard]] std::string log() const { return file_contents(log_); }
  [[nodiscard]] int port() const { return port_; }
  [[nodiscard]] std::string url() const { return "http://127.0.0.1:" + std::to_string(port_); }
  httplib::Client& http() { return client_; }

  json get(const std::string& path, int expected_status = 200) {
    auto res = client_.Get(path);
    EXPECT_TRUE(res) << path;
    if (!res) return nullptr;
    EXPECT_EQ(res->status, expected_status) << path << ": " << res->body;
    return json::parse(res->body, nullptr, false);
  }
  std::int64_t submit(const json& body) {
    auto res = client_.Post("/v1/scans", body.dump(), "application/json");
    EXPECT_TRUE(res);
    if (!res) return -1;
    EXPECT_EQ(res->status, 202) << res->body;
    return json::parse(res->body).value("id", std::int64_t{-1});
  }
  // The scan's row once it has finished (or after `limit`).
  json wait_finished(std::int64_t id, std::chrono::seconds limit = 30s) {
    const auto deadline = std::chrono::steady_clock::now() + limit;
    json entry;
    while (std::chrono::steady_clock::now() < deadline) {
      entry = get("/v1/scans/" + std::to_string(id));
      const std::string status = entry.value("status", "");
      if (status != "queued" && status != "running") return entry;
      std::this_thread::sleep_for(20ms);
    }
    ADD_FAILURE() << "scan " << id << " did not finish: " << entry.dump();
    return entry;
  }
  // Waits until `predicate` holds of GET /v1/status.
  template <class Predicate>
  bool wait_status(Predicate predicate, std::chrono::seconds limit = 20s) {
    const auto deadline = std::chrono::steady_clock::now() + limit;
    while (std::chrono::steady_clock::now() < deadline) {
      if (auto res = client_.Get("/v1/status"); res && res->status == 200)
        if (predicate(json::parse(res->body))) return true;
      std::this_thread::sleep_for(2ms);
    }
    return false;
  }

  // `path` as the daemon sees it, through its own root: inside its private
  // tmpfs when it has one.
  [[nodiscard]] fs::path seen_by_daemon(const fs::path& path) const {
    return fs::path("/proc") / std::to_string(pid_) / "root" / path.relative_path();
  }

 private:
  // fork, not posix_spawn: the child must enter its namespace before exec.
  void spawn_with_tmpfs(const ProgramCommand& command, const PrivateTmpfs& tmpfs) {
    const std::string at = tmpfs.at.string(), log = log_.string();
    pid_ = ::fork();
    if (pid_ == 0) {
      if (mount_private_tmpfs(at.c_str(), tmpfs.options.c_str()) != 0) ::_exit(kTmpfsFailed);
      const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
      if (fd > 2) {
        ::dup2(fd, 2);
        ::close(fd);
      }
      ::execve(command.file().c_str(), command.argv(), environ);
      ::_exit(127);
    }
    if (pid_ < 0) pid_ = 0;
  }

  pid_t pid_ = 0;
  int exit_code_ = -1;
  int port_;
  fs::path log_;
  httplib::Client client_;
};

}  // namespace psrig::test
