#pragma once
// The `psrig` commands that talk to a running psrigd (`status`,
// `scan --remote`): its URL, the bearer token, and JSON requests whose
// failures come back as Errors that say what to check.

#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "psrig/base/error.h"

namespace httplib {
class Client;
}

namespace psrig::capture::cli {

inline constexpr const char* kDefaultDaemonUrl = "http://127.0.0.1:8470";

// Whether `url` is a daemon's address, http://HOST[:PORT]; the error names
// `option` (--url, --remote) and says what is expected.
[[nodiscard]] Status check_daemon_url(const std::string& url, const std::string& option);

struct DaemonReply {
  int status = 0;
  nlohmann::json body;
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

}  // namespace psrig::capture::cli
