#include "daemon_client.h"

#include <cstdlib>
#include <httplib.h>
#include <string_view>

namespace psrig::capture::cli {

Status check_daemon_url(const std::string& url, const std::string& option) {
  constexpr std::string_view kScheme = "http://";
  std::string_view rest(url);
  bool ok = rest.starts_with(kScheme);
  if (ok) {
    rest.remove_prefix(kScheme.size());
    if (rest.ends_with('/')) rest.remove_suffix(1);
    auto colon = rest.rfind(':');
    if (const auto bracket = rest.rfind(']');  // http://[::1]: the colons are the address's
        bracket != std::string_view::npos && colon != std::string_view::npos && colon < bracket)
      colon = std::string_view::npos;
    const std::string_view host = rest.substr(0, colon);
    ok = !host.empty() && host.find_first_of("/?#@ ") == std::string_view::npos;
    if (ok && colon != std::string_view::npos) {
      const std::string_view port = rest.substr(colon + 1);
      ok = !port.empty() && port.size() <= 5 &&
           port.find_first_not_of("0123456789") == std::string_view::npos &&
           std::stoi(std::string(port)) <= 65535;
    }
  }
  if (ok) return {};
  return std::unexpected(bad_input(
      url, option,
      std::string("not a URL (expected http://HOST:PORT, e.g. ") + kDefaultDaemonUrl + ")"));
}

DaemonClient::DaemonClient(std::string url, std::string token) : url_(std::move(url)) {
  if (token.empty())
    if (const char* from_environment = std::getenv("PSRIG_TOKEN")) token = from_environment;
  client_ = std::make_unique<httplib::Client>(url_);
  client_->set_connection_timeout(std::chrono::seconds(3));
  client_->set_read_timeout(std::chrono::seconds(10));
  client_->set_write_timeout(std::chrono::seconds(10));
  if (!token.empty()) client_->set_bearer_token_auth(token.c_str());
}

DaemonClient::~DaemonClient() = default;

template <class Call>
Result<DaemonReply> DaemonClient::request(const std::string& what, Call call) {
  if (!client_->is_valid())
    return std::unexpected(bad_input(
        "", "--url", url_ + ": not a daemon URL (expected e.g. " + kDefaultDaemonUrl + ")"));
  const httplib::Result result = call();
  if (!result)
    return std::unexpected(io_error(url_, "cannot reach psrigd (" +
                                              httplib::to_string(result.error()) + " on " + what +
                                              "); is it running, and is this its address?"));
  if (result->status == 401)
    return std::unexpected(
        bad_input(url_, "", "psrigd wants a bearer token: give --token or set PSRIG_TOKEN"));
  DaemonReply reply;
  reply.status = result->status;
  reply.body = nlohmann::json::parse(result->body, nullptr, false);
  if (reply.body.is_discarded())
    return std::unexpected(io_error(
        url_, what + ": answered HTTP " + std::to_string(result->status) + " but not in JSON"));
  return reply;
}

Result<DaemonReply> DaemonClient::get(const std::string& path) {
  return request("GET " + path, [&] { return client_->Get(path); });
}

Result<DaemonReply> DaemonClient::post(const std::string& path, const nlohmann::json& body) {
  return request("POST " + path,
                 [&] { return client_->Post(path, body.dump(), "application/json"); });
}

std::string reply_error(const DaemonReply& reply) {
  if (reply.body.is_object() && reply.body.contains("error") && reply.body["error"].is_string())
    return reply.body["error"].get<std::string>();
  return "HTTP " + std::to_string(reply.status);
}

std::string reply_text(const nlohmann::json& value) {
  return value.is_string() ? value.get<std::string>() : value.dump();
}

}  // namespace psrig::capture::cli
