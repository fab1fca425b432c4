#include "daemon_client.h"

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <httplib.h>
#include <string_view>

namespace psrig::cli {

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

Status DaemonClient::follow_events(std::uint64_t after, const std::function<void()>& on_open,
                                   const std::function<bool(DaemonEvent)>& on_event) {
  if (!client_->is_valid())
    return std::unexpected(bad_input(
        "", "--url", url_ + ": not a daemon URL (expected e.g. " + kDefaultDaemonUrl + ")"));
  // psrigd writes a heartbeat every 15 s on a quiet stream.
  client_->set_read_timeout(std::chrono::seconds(40));
  httplib::Headers headers{{"Accept", "text/event-stream"}};
  if (after > 0) headers.emplace("Last-Event-ID", std::to_string(after));
  int status = 0;
  std::string refusal;  // the body of an answer other than 200
  std::string pending;  // received, not yet a whole line
  DaemonEvent event;
  std::string data;
  bool enough = false;
  // One line of the stream (text/event-stream: field ": " value; a blank
  // line ends an event; a leading colon is a comment). False: stop.
  const auto take_line = [&](std::string line) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) {
      if (!data.empty()) {
        event.data = nlohmann::json::parse(data, nullptr, false);
        if (!on_event(std::move(event))) return false;
      }
      event = {};
      data.clear();
      return true;
    }
    if (line.front() == ':') return true;
    const auto colon = line.find(':');
    const std::string field = line.substr(0, colon);
    std::string value = colon == std::string::npos ? "" : line.substr(colon + 1);
    if (value.starts_with(' ')) value.erase(0, 1);
    if (field == "event") {
      event.type = value;
    } else if (field == "data") {
      if (!data.empty()) data += '\n';
      data += value;
    } else if (field == "id") {
      std::uint64_t sequence = 0;
      const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), sequence);
      if (ec == std::errc() && end == value.data() + value.size()) event.sequence = sequence;
    }
    return true;
  };
  const httplib::Result result = client_->Get(
      "/v1/events", headers,
      [&](const httplib::Response& response) {
        status = response.status;
        if (status == 200 && on_open) on_open();
        return true;
      },
      [&](const char* bytes, std::size_t length) {
        if (status != 200) {
          refusal.append(bytes, std::min<std::size_t>(length, 4096));
          return refusal.size() < 4096;
        }
        pending.append(bytes, length);
        for (auto end = pending.find('\n'); end != std::string::npos; end = pending.find('\n')) {
          std::string line = pending.substr(0, end);
          pending.erase(0, end + 1);
          if (!take_line(std::move(line))) {
            enough = true;
            return false;
          }
        }
        return true;
      });
  if (enough) return {};
  if (status == 401)
    return std::unexpected(
        bad_input(url_, "", "psrigd wants a bearer token: give --token or set PSRIG_TOKEN"));
  if (status != 0 && status != 200) {
    DaemonReply reply{status, nlohmann::json::parse(refusal, nullptr, false)};
    return std::unexpected(io_error(url_, "GET /v1/events: " + reply_error(reply)));
  }
  if (!result)
    return std::unexpected(io_error(url_, "cannot follow psrigd's events (" +
                                              httplib::to_string(result.error()) +
                                              " on GET /v1/events)"));
  return std::unexpected(io_error(url_, "psrigd ended its event stream (stopping?)"));
}

void DaemonClient::stop() {
  client_->stop();
}

std::string reply_error(const DaemonReply& reply) {
  if (reply.body.is_object() && reply.body.contains("error") && reply.body["error"].is_string())
    return reply.body["error"].get<std::string>();
  return "HTTP " + std::to_string(reply.status);
}

std::string reply_text(const nlohmann::json& value) {
  return value.is_string() ? value.get<std::string>() : value.dump();
}

}  // namespace psrig::cli
