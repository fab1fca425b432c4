#pragma once
// The `psrig` commands that talk to a running psrigd (`status`,
// `scan --remote`): its URL, the bearer token, and JSON requests whose
// failures come back as Errors that say what to check.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "psrig/base/error.h"

namespace httplib {
class Client;
}

namespace psrig::cli {

inline constexpr const char* kDefaultDaemonUrl = "http://127.0.0.1:8470";

// Whether `url` is a daemon's address, http://HOST[:PORT]; the error names
// `option` (--url, --remote) and says what is expected.
[[nodiscard]] Status check_daemon_url(const std::string& url, const std::string& option);

struct DaemonReply {
  int status = 0;
  nlohmann::json body;
};

// One server-sent event of GET /v1/events.
struct DaemonEvent {
  std::uint64_t sequence = 0;  // its `id:`, for Last-Event-ID
  std::string type;            // "progress", "done", "error"
  nlohmann::json data;         // carries the scan's "id"
};

class DaemonClient {
 public:
  // `token` empty: $PSRIG_TOKEN, if set.
  DaemonClient(std::string url, std::string token);
  ~DaemonClient();
  DaemonClient(const DaemonClient&) = delete;
  DaemonClient& operator=(const DaemonClient&) = delete;

  // Any HTTP answer; an error only when there was none (no daemon there,
  // a bad URL) or it was not JSON. 401 becomes a bad_input error naming
  // --token.
  [[nodiscard]] Result<DaemonReply> get(const std::string& path);
  [[nodiscard]] Result<DaemonReply> post(const std::string& path, const nlohmann::json& body);

  // Follows GET /v1/events on this client's connection: `on_open` once
  // psrigd has answered (every event it publishes from then on comes),
  // then each event as it arrives (those after `after` first, when psrigd
  // still holds them), until `on_event` returns false (then success),
  // stop() is called, or the stream fails or ends (then an error saying
  // why: no daemon, too many streams, the daemon stopping).
  [[nodiscard]] Status follow_events(std::uint64_t after, const std::function<void()>& on_open,
                                     const std::function<bool(DaemonEvent)>& on_event);
  // From another thread: ends the request in progress (follow_events).
  void stop();

  [[nodiscard]] const std::string& url() const { return url_; }

 private:
  template <class Call>
  Result<DaemonReply> request(const std::string& what, Call call);

  std::string url_;
  std::unique_ptr<httplib::Client> client_;
};

// The "error" of a JSON error reply, or the status when it has none.
[[nodiscard]] std::string reply_error(const DaemonReply& reply);

// A value of a reply as people read it: a string as it is, anything else as JSON.
[[nodiscard]] std::string reply_text(const nlohmann::json& value);

}  // namespace psrig::cli
