// HTTP requests, as psrigd's API takes them: a ScanService over the
// simulated rig (config/sim.toml at 160x120, queue of 2, scans in a scratch
// directory) and HttpApi::start() on a free 127.0.0.1 port, both started
// once; each input is written on a new connection as it is (a request, a
// few pipelined, or garbage), the answer given 15 ms to begin, the writing
// side shut, and the answer read until the server closes, the head of an
// event stream has come (it never ends), or a deadline of 1 s. Scans the inputs submit really run, on the
// simulated rig, and inputs can cancel, abort, list and fetch them.
//
// Besides crashes and sanitizer reports (on the server's threads too), one
// oracle: whatever the server sends starts with an HTTP/1.1 status line and
// is never a 5xx other than 501 (a transfer coding it does not know), 503
// (a full queue), 505 or 507 (no room on disk): a 500 is the service's own
// failure on a request.

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>

#include "fuzz_support.h"
#include "psrig/config/config_loader.h"
#include "psrig/daemon/http_api.h"
#include "psrig/daemon/scan_service.h"

namespace {

using namespace psrig;

struct Fixture {
  std::unique_ptr<daemon::ScanService> service;
  std::unique_ptr<daemon::HttpApi> api;
  int port = 0;

  Fixture() {
    const auto dir = fuzz::scratch_directory();
    std::ifstream in(std::filesystem::path(PSRIG_SOURCE_DIR) / "config/sim.toml");
    std::stringstream buffer;
    buffer << in.rdbuf();
    std::string text = buffer.str();
    const auto replace = [&](const std::string& from, const std::string& to) {
      const auto at = text.find(from);
      if (at == std::string::npos) {
        std::fprintf(stderr, "fuzz_http_request: config/sim.toml has no \"%s\"\n", from.c_str());
        std::abort();
      }
      text.replace(at, from.size(), to);
    };
    replace("width = 640", "width = 160");
    replace("height = 480", "height = 120");
    replace("root = \"../out/scans\"", "root = \"scans\"");
    replace("queue_limit = 16", "queue_limit = 2");
    auto config = config::parse_config(text, dir / "rig.toml");
    if (!config) fail(config.error());
    auto started = daemon::ScanService::start(*config);
    if (!started) fail(started.error());
    service = std::move(*started);
    daemon::HttpApiOptions options = daemon::http_api_options(config->daemon);
    // HttpApi::port() gives back the port asked for, so ask for a free one
    // (another process may take it in between: then try again).
    for (int attempt = 0; attempt < 20 && !api; ++attempt) {
      options.port = fuzz::free_loopback_port();
      auto serving = daemon::HttpApi::start(*service, options);
      if (serving) {
        api = std::move(*serving);
        port = options.port;
      } else if (attempt == 19) {
        fail(serving.error());
      }
    }
  }
  [[noreturn]] static void fail(const Error& error) {
    std::fprintf(stderr, "fuzz_http_request: %s\n", error.describe().c_str());
    std::abort();
  }
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

void check(const std::string& answer) {
  if (answer.empty()) return;  // closed without a word: a request it gave up on
  const bool status_line = answer.starts_with("HTTP/1.1 ") && answer.size() >= 12;
  const std::string code = status_line ? answer.substr(9, 3) : "";
  if (!status_line || (code[0] == '5' && code != "501" && code != "503" && code != "505" && code != "507")) {
    std::fprintf(stderr, "fuzz_http_request: the answer begins \"%s\"\n",
                 answer.substr(0, std::min<std::size_t>(answer.size(), 200)).c_str());
    std::abort();
  }
}

// Exit (libFuzzer's, or the replay's) destroys statics in the reverse order
// of their making, and the server's threads make some of their own while
// they work (a logger, the lights' emergency-stop registry), after the
// fixture was made: destroyed first, under threads still running. So the
// servers are stopped by an exit handler registered anew with every input,
// which therefore runs before any static made while the inputs ran is
// destroyed. (One small entry per input; the second run finds nothing to stop.)
void stop_servers() {
  auto& f = fixture();
  f.api.reset();  // stops and destroys it while everything it uses is alive
  f.service.reset();
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  fuzz::quiet_logs();
  (void)fixture();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::atexit(stop_servers);
  // httplib writes nothing to a peer that has shut its writing side, so the
  // answer to a whole request is given 15 ms to begin before the input ends.
  check(fuzz::exchange(fixture().port, data, size, 1000, 15, "text/event-stream"));
  return 0;
}
