#include "psrig/daemon/http_api.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <httplib.h>
#include <limits>
#include <regex>
#include <set>
#include <string_view>
#include <thread>

#include "fronted_server.h"
#include "http_answers.h"
#include "psrig/base/log.h"
#include "psrig/calibration/calibration_status.h"
#include "psrig/daemon/status_json.h"
#include "psrig/formats/scan_layout.h"
#include "psrig/rig/rig_calibration.h"
#include "rig_forwarding.h"
#include "scan_exports.h"
#include "scan_previews.h"
#include "web_catalogue.h"

namespace psrig::daemon {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr std::size_t kMaxSampleId = 128;
constexpr std::size_t kMaxDescription = 4096;
constexpr std::size_t kMaxTags = 32;
constexpr std::size_t kMaxTag = 64;
constexpr int kMaxSearchLimit = 1000;
// An idle event stream sends a comment this often: proxies keep it open,
// and a listener that has gone is noticed.
constexpr auto kHeartbeat = std::chrono::seconds(15);
constexpr auto kEventPoll = std::chrono::milliseconds(250);

// The files of `directory` that scan_file_home() places there, by name.
void add_files_from(const fs::path& directory, ScanFileHome home, std::set<std::string>& names) {
  if (directory.empty()) return;
  std::error_code ec;
  for (fs::directory_iterator it(directory, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code type_ec;
    const std::string name = it->path().filename().string();
    if (scan_file_home(name) == home && it->is_regular_file(type_ec)) names.insert(name);
  }
}

std::string content_type(const std::string& name) {
  if (name.ends_with(".png")) return "image/png";
  if (name.ends_with(".exr")) return "image/x-exr";
  if (name.ends_with(".tif") || name.ends_with(".tiff")) return "image/tiff";
  if (name.ends_with(".json")) return "application/json";
  return "application/octet-stream";
}

// A refusal after which the connection is closed, for a request whose body
// is left unread: the rest of it must not be read as the next request.
// httplib 0.11 closes a connection only where the request asked for it (or
// a write fails), whatever the response says; so the answer is written by a
// provider that then reports failure, which ends the connection once the
// answer is out.
void refuse_and_close(httplib::Response& res, int status, const std::string& message) {
  res.status = status;
  res.set_header("Connection", "close");
  auto text = std::make_shared<const std::string>(to_text({{"error", message}}) + "\n");
  res.set_content_provider(text->size(), "application/json",
                           [text](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
                             sink.write(text->data() + offset, length);
                             return false;  // written: now close
                           });
}

json entry_json(const catalogue::CatalogueEntry& e) {
  std::set<std::string> names;
  add_files_from(e.scan_directory, ScanFileHome::scan, names);
  add_files_from(e.maps_directory, ScanFileHome::maps, names);
  json files = json::array();
  for (const auto& name : names)
    files.push_back(name);
  const auto optional_text = [](const std::string& text) -> json {
    return text.empty() ? json(nullptr) : json(text);
  };
  return {
      {"id", e.id},
      {"rig", e.rig},
      {"sample_id", e.sample_id},
      {"description", e.description},
      {"tags", e.tags},
      {"source", e.source},
      {"status", to_string(e.status)},
      {"created", e.created},
      {"started", optional_text(e.started)},
      {"finished", optional_text(e.finished)},
      {"error", e.error_code == catalogue::ScanErrorCode::none && e.error_message.empty()
                    ? json(nullptr)
                    : json{{"code", static_cast<int>(e.error_code)},
                           {"code_name", to_string(e.error_code)},
                           {"message", e.error_message}}},
      {"scan_directory", optional_text(e.scan_directory.string())},
      {"maps_directory", optional_text(e.maps_directory.string())},
      {"files", files},
      {"report", e.report},
  };
}

// A JSON string field of the submission, when present: its value, or why not.
std::optional<std::string> string_field(const json& body, const char* key, std::size_t max,
                                        std::string& value) {
  if (!body.contains(key)) return std::nullopt;
  const auto& field = body[key];
  if (!field.is_string()) return std::string(key) + ": expected a string";
  value = field.get<std::string>();
  if (value.size() > max)
    return std::string(key) + ": longer than " + std::to_string(max) + " bytes";
  return std::nullopt;
}

// The POST routes, each reading its body through read_body(): the only
// ones that take a chunked body.
const char* const kScansRoute = "/v1/scans";
const char* const kCancelRoute = R"(/v1/scans/([^/]+)/cancel)";
const char* const kLightsOffRoute = "/v1/lights/off";
const char* const kCalibrationsRoute = "/v1/calibrations";

bool reads_body(const httplib::Request& req) {
  static const std::array<std::regex, 4> routes = {
      std::regex(kScansRoute), std::regex(kCancelRoute), std::regex(kLightsOffRoute),
      std::regex(kCalibrationsRoute)};
  return req.method == "POST" && std::ranges::any_of(routes, [&](const std::regex& route) {
           return std::regex_match(req.path, route);
         });
}

// A header's value is `word` (a coding's name), in any case.
bool names(std::string value, std::string_view word) {
  std::ranges::transform(value, value.begin(), [](unsigned char c) { return std::tolower(c); });
  return value == word;
}

// The request's body, however it is sent (Content-Length, chunked, none),
// read up to `max` bytes and no further. Nothing (the refusal in `res`,
// closing the connection) when it is larger or cannot be read.
std::optional<std::string> read_body(const httplib::Request& req,
                                     const httplib::ContentReader& reader, std::size_t max,
                                     httplib::Response& res) {
  if (req.is_multipart_form_data()) {
    refuse_and_close(res, 415, "expected a JSON body, not multipart/form-data");
    return std::nullopt;
  }
  std::string body;
  bool too_large = false;
  const bool read = reader([&](const char* data, std::size_t length) {
    if (body.size() + length > max) {
      too_large = true;
      return false;  // httplib stops reading here
    }
    body.append(data, length);
    return true;
  });
  if (read) return body;
  if (too_large)
    refuse_and_close(res, 413, "request body larger than " + std::to_string(max) + " bytes");
  else
    refuse_and_close(res, 400, "the request body could not be read");
  return std::nullopt;
}

}  // namespace

std::optional<ScanFileHome> scan_file_home(const std::string& name) {
  // A map first: the maps' mask.png is the one served by that name.
  if (formats::map_files::is_map_file(name)) return ScanFileHome::maps;
  if (formats::scan_files::is_scan_file(name)) return ScanFileHome::scan;
  return std::nullopt;
}

bool constant_time_equal(const std::string& a, const std::string& b) {
  // Every byte of the longer is looked at, whatever matches.
  const std::size_t n = std::max(a.size(), b.size());
  unsigned char difference = a.size() == b.size() ? 0 : 1;
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char x = i < a.size() ? static_cast<unsigned char>(a[i]) : 0;
    const unsigned char y = i < b.size() ? static_cast<unsigned char>(b[i]) : 0;
    difference |= static_cast<unsigned char>(x ^ y);
  }
  return difference == 0;
}

HttpApiOptions http_api_options(const config::DaemonConfig& daemon) {
  HttpApiOptions options;
  options.address = daemon.listen_address;
  options.port = daemon.port;
  options.token = daemon.token;
  options.web_root = find_web_root(daemon);
  return options;
}

namespace {

// What the front serves on threads of their own: switching the LEDs off,
// and seeing that they are.
bool is_safety_route(std::string_view method, std::string_view path) {
  return (method == "POST" && path == kLightsOffRoute) || (method == "GET" && path == "/v1/status");
}

ServingLimits serving_limits(const HttpApiOptions& options) {
  ServingLimits limits;
  limits.general_threads = std::max(2, options.threads);
  return limits;
}

}  // namespace

struct HttpApi::Impl {
  Impl(ScanService& s, HttpApiOptions o)
      : service(s), options(std::move(o)), server(serving_limits(options), is_safety_route) {}

  ScanService& service;
  const HttpApiOptions options;
  FrontedServer server;
  std::thread listener;
  std::atomic<bool> stopping{false};
  std::atomic<int> event_streams{0};
  int port = 0;
  ScanExports exports;  // GET /v1/scans/{id}/export/{format} (scan_exports.h)

  void routes();
  void status(httplib::Response& res);
  void submit(const std::string& text, httplib::Response& res);
  void search(const httplib::Request& req, httplib::Response& res);
  void get(const httplib::Request& req, httplib::Response& res);
  void file(const httplib::Request& req, httplib::Response& res);
  void preview(const httplib::Request& req, httplib::Response& res);
  void remove(const httplib::Request& req, httplib::Response& res);
  void cancel(const httplib::Request& req, httplib::Response& res);
  void events(const httplib::Request& req, httplib::Response& res);
  void lights_off(httplib::Response& res);
  void calibrate(const std::string& text, httplib::Response& res);
  void calibrations(httplib::Response& res);
  void current_calibration(httplib::Response& res);
  void rigs(httplib::Response& res);
  // A row of another rig of the shared catalogue: that rig's own psrigd
  // answers for it (rig_forwarding.h). False when it is this rig's.
  bool belongs_elsewhere(const catalogue::CatalogueEntry& entry);
  void forward(const std::string& rig, const std::string& method, const std::string& path,
               const std::string& body, httplib::Response& res);
};

namespace {

// A catalogue that could not answer: the database away is the service's
// state for now (503, try again), anything else the daemon's trouble.
void catalogue_failure(httplib::Response& res, const Error& error) {
  if (error.code == ErrorCode::unavailable) {
    res.set_header("Retry-After", "5");
    return refuse(res, 503, error.describe());
  }
  refuse(res, 500, error.describe());
}

}  // namespace

void HttpApi::Impl::routes() {
  auto log = logger("http");
  const std::string token = options.token;
  const std::size_t max_body = options.max_body_bytes;
  server.set_pre_routing_handler(
      [token, max_body](const httplib::Request& req, httplib::Response& res) {
        // Every refusal closes the connection: a body left unread must not be
        // taken for the next request.
        const auto close_with = [&res](int status, const std::string& message) {
          refuse_and_close(res, status, message);
          return httplib::Server::HandlerResponse::Handled;
        };
        // The catalogue's pages need no token (they ask for it, for the API).
        const bool page = !is_api_path(req.path) && (req.method == "GET" || req.method == "HEAD");
        if (!token.empty() && !page &&
            !constant_time_equal(req.get_header_value("Authorization"), "Bearer " + token)) {
          res.set_header("WWW-Authenticate", "Bearer");
          return close_with(401, "missing or wrong bearer token (Authorization: Bearer TOKEN)");
        }
        const bool has_length = req.has_header("Content-Length");
        if (req.has_header("Transfer-Encoding")) {
          // httplib 0.11 reads a chunked body whole into memory, unbounded
          // (its payload limit applies to Content-Length only), and reads any
          // other coding until the connection closes. Only the routes that read
          // their body through read_body(), which stops at the limit, take one.
          if (has_length) return close_with(400, "both Content-Length and Transfer-Encoding");
          if (!names(req.get_header_value("Transfer-Encoding"), "chunked"))
            return close_with(501, "Transfer-Encoding: only chunked is understood");
          if (!reads_body(req)) return close_with(413, "this endpoint takes no request body");
        }
        if (req.has_header("Content-Encoding") &&
            !names(req.get_header_value("Content-Encoding"), "identity"))
          // A compressed body would be inflated past the limit.
          return close_with(415, "Content-Encoding: bodies are taken uncompressed only");
        // Refused from the headers: httplib would first read (or wait for) a
        // body it is going to refuse, holding a thread for its read timeout.
        const auto length = has_length ? req.get_header_value<std::uint64_t>("Content-Length") : 0;
        if (length > max_body)
          return close_with(413, "request body larger than " + std::to_string(max_body) + " bytes");
        // httplib reads no body for the other methods (GET, HEAD, OPTIONS):
        // one sent would be read as the next request.
        static const std::set<std::string> with_body = {"POST", "PUT", "PATCH", "DELETE", "PRI"};
        if (length > 0 && !with_body.contains(req.method))
          return close_with(413, req.method + " takes no request body");
        // Neither header: the body is empty (RFC 9112 6.3), as curl -X POST
        // sends it. httplib 0.11 would read it until the connection closes
        // (its read timeout, then 400); it reads the body only after this
        // handler, from a Request it owns as non-const, so the length is
        // stated for it.
        if (!has_length && !req.has_header("Transfer-Encoding"))
          const_cast<httplib::Request&>(req).headers.emplace("Content-Length", "0");
        return httplib::Server::HandlerResponse::Unhandled;
      });
  // Whatever httplib refuses by itself (no route, body too large, bad
  // request line) still answers in JSON.
  server.set_error_handler(httplib::Server::HandlerWithResponse(
      [max_body](const httplib::Request&, httplib::Response& res) {
        // Ours already (refuse_and_close() answers through a provider).
        if (!res.body.empty() || res.has_header("Connection"))
          return httplib::Server::HandlerResponse::Unhandled;
        std::string message;
        switch (res.status) {
          case 404:
            message = "no such endpoint";
            break;
          case 405:
            message = "method not allowed here";
            break;
          case 413:
            message = "request body larger than " + std::to_string(max_body) + " bytes";
            break;
          case 414:
            message = "request URI too long";
            break;
          case 400:
            message = "malformed request";
            break;
          default:
            message = "request failed (HTTP " + std::to_string(res.status) + ")";
        }
        refuse(res, res.status, message);
        return httplib::Server::HandlerResponse::Handled;
      }));
  server.set_exception_handler(
      [log](const httplib::Request& req, httplib::Response& res, std::exception_ptr error) {
        std::string what = "unknown";
        try {
          if (error) std::rethrow_exception(error);
        } catch (const std::exception& e) {
          what = e.what();
        } catch (...) {
        }
        log->error("{} {}: {}", req.method, req.path, what);
        refuse(res, 500, "internal error: " + what);
      });
  server.set_logger([log](const httplib::Request& req, const httplib::Response& res) {
    log->debug("{} {} -> {}", req.method, req.path, res.status);
  });

  serve_web_catalogue(server, options.web_root);
  server.Get("/v1/status",
             [this](const httplib::Request&, httplib::Response& res) { status(res); });
  server.Post(kScansRoute, [this](const httplib::Request& req, httplib::Response& res,
                                  const httplib::ContentReader& reader) {
    if (auto body = read_body(req, reader, options.max_body_bytes, res)) submit(*body, res);
  });
  server.Get("/v1/scans",
             [this](const httplib::Request& req, httplib::Response& res) { search(req, res); });
  server.Get(R"(/v1/scans/([^/]+))",
             [this](const httplib::Request& req, httplib::Response& res) { get(req, res); });
  server.Get(R"(/v1/scans/([^/]+)/files/(.*))",
             [this](const httplib::Request& req, httplib::Response& res) { file(req, res); });
  server.Get(R"(/v1/scans/([^/]+)/(thumbnail|relit))",
             [this](const httplib::Request& req, httplib::Response& res) { preview(req, res); });
  server.Get(R"(/v1/scans/([^/]+)/export/([^/]+))",
             [this](const httplib::Request& req, httplib::Response& res) {
               serve_scan_export(service.catalogue(), exports, req, res);
             });
  server.Delete(R"(/v1/scans/([^/]+))",
                [this](const httplib::Request& req, httplib::Response& res) { remove(req, res); });
  server.Post(kCancelRoute, [this](const httplib::Request& req, httplib::Response& res,
                                   const httplib::ContentReader& reader) {
    if (read_body(req, reader, options.max_body_bytes, res)) cancel(req, res);
  });
  server.Get("/v1/events",
             [this](const httplib::Request& req, httplib::Response& res) { events(req, res); });
  server.Post(kLightsOffRoute, [this](const httplib::Request& req, httplib::Response& res,
                                      const httplib::ContentReader& reader) {
    if (read_body(req, reader, options.max_body_bytes, res)) lights_off(res);
  });
  server.Post(kCalibrationsRoute, [this](const httplib::Request& req, httplib::Response& res,
                                         const httplib::ContentReader& reader) {
    if (auto body = read_body(req, reader, options.max_body_bytes, res)) calibrate(*body, res);
  });
  server.Get(kCalibrationsRoute,
             [this](const httplib::Request&, httplib::Response& res) { calibrations(res); });
  server.Get("/v1/calibrations/current",
             [this](const httplib::Request&, httplib::Response& res) { current_calibration(res); });
  server.Get("/v1/rigs", [this](const httplib::Request&, httplib::Response& res) { rigs(res); });
}

// GET /v1/rigs: every rig the catalogue knows, its status and whether it
// is online.
void HttpApi::Impl::rigs(httplib::Response& res) {
  auto rigs = service.catalogue().rigs();
  if (!rigs) return catalogue_failure(res, rigs.error());
  json answer = rigs_json(*rigs, service.has_rig() ? service.catalogue().rig_name() : "");
  answer["role"] = service.config().daemon.role;
  reply(res, 200, answer);
}

bool HttpApi::Impl::belongs_elsewhere(const catalogue::CatalogueEntry& entry) {
  return config::is_shared_catalogue(service.config().catalogue) &&
         (!service.has_rig() || entry.rig != service.catalogue().rig_name());
}

void HttpApi::Impl::forward(const std::string& rig_name, const std::string& method,
                            const std::string& path, const std::string& body,
                            httplib::Response& res) {
  auto rig = find_rig(service.catalogue(), rig_name);
  if (!rig)
    return rig.error().kind == ErrorKind::bad_input ? refuse(res, 404, rig.error().message)
                                                    : catalogue_failure(res, rig.error());
  auto answer = forward_to_rig(*rig, method, path, body);
  if (!answer)
    return refuse(res, answer.error().code == ErrorCode::unavailable ? 502 : 400,
                  answer.error().describe());
  json reply_body = json::parse(answer->body, nullptr, false);
  if (!reply_body.is_object())
    return refuse(res, 502, "rig " + rig_name + " answered HTTP " +
                                std::to_string(answer->status) + " without JSON");
  reply_body["rig"] = rig_name;
  if (answer->status == 202 && reply_body.contains("id") && reply_body["id"].is_number_integer())
    res.set_header("Location", "/v1/scans/" + std::to_string(reply_body["id"].get<std::int64_t>()));
  reply(res, answer->status, reply_body);
}

// POST /v1/calibrations {"kind", …options}: queued with the scans.
void HttpApi::Impl::calibrate(const std::string& text, httplib::Response& res) {
  if (!service.has_rig()) return refuse(res, 409, service.no_rig_error().message);
  const json body = json::parse(text, nullptr, false);
  if (body.is_discarded()) return refuse(res, 400, "malformed JSON in the request body");
  if (!body.is_object()) return refuse(res, 400, "expected a JSON object");
  std::string kinds;
  for (const auto& kind : rig::calibration_kinds())
    kinds += (kinds.empty() ? "" : ", ") + kind;
  if (!body.contains("kind") || !body["kind"].is_string())
    return refuse(res, 400, "kind: expected a string (" + kinds + ")");
  rig::CalibrationRequest request;
  request.kind = body["kind"].get<std::string>();
  if (!rig::calibration_kind_supported(request.kind))
    return refuse(res, 400, "kind: \"" + request.kind + "\" is not supported (" + kinds + ")");
  // The options of `psrig calibrate KIND` that need no files on this machine.
  const auto whole = [&](const char* key, int& out, int lo, int hi) -> std::optional<std::string> {
    if (!body.contains(key)) return std::nullopt;
    if (!body[key].is_number_integer() || body[key].get<std::int64_t>() < lo ||
        body[key].get<std::int64_t>() > hi)
      return std::string(key) + ": expected a whole number, " + std::to_string(lo) + " to " +
             std::to_string(hi);
    out = body[key].get<int>();
    return std::nullopt;
  };
  const auto positive = [&](const char* key, double& out) -> std::optional<std::string> {
    if (!body.contains(key)) return std::nullopt;
    if (!body[key].is_number() || !(body[key].get<double>() > 0) ||
        !(body[key].get<double>() < 1e6))
      return std::string(key) + ": expected a positive number";
    out = body[key].get<double>();
    return std::nullopt;
  };
  const auto text_field = [&](const char* key, std::string& out) -> std::optional<std::string> {
    return string_field(body, key, 64, out);
  };
  std::set<std::string> allowed = {"kind", "frames"};
  if (request.kind == "lights") allowed.insert({"target", "places", "sphere_mm", "focal_px"});
  if (request.kind == "scale") allowed.insert({"squares", "square_mm", "marker_mm", "dictionary"});
  for (const auto& [key, value] : body.items())
    if (!allowed.contains(key)) {
      std::string list;
      for (const auto& a : allowed)
        list += (list.empty() ? "" : ", ") + a;
      return refuse(res, 400,
                    key + ": unknown field for kind " + request.kind + " (expected " + list + ")");
    }
  std::optional<std::string> problem;
  if (request.kind == "scale" && body.contains("frames"))
    problem = "frames: the scale takes one capture";
  if (!problem) problem = whole("frames", request.frames, 1, 64);
  if (!problem) problem = whole("places", request.places, 1, 16);
  if (!problem && body.contains("target")) {
    problem = text_field("target", request.target);
    if (!problem && request.target != "chrome" && request.target != "matte")
      problem = "target: expected \"chrome\" or \"matte\"";
  }
  double number = 0;
  if (!problem && body.contains("sphere_mm") && !(problem = positive("sphere_mm", number)))
    request.sphere_mm = number;
  if (!problem && body.contains("focal_px") && !(problem = positive("focal_px", number)))
    request.focal_px = number;
  if (!problem) problem = text_field("squares", request.squares);
  if (!problem) problem = positive("square_mm", request.square_mm);
  if (!problem) problem = positive("marker_mm", request.marker_mm);
  if (!problem) problem = text_field("dictionary", request.dictionary);
  if (problem) return refuse(res, 400, *problem);
  auto id = service.submit_calibration(body, std::move(request));
  if (!id) {
    if (id.error().code == ErrorCode::queue_full) {
      res.set_header("Retry-After", "5");
      return refuse(res, 503, id.error().message);
    }
    return refuse(res, 503, id.error().describe());
  }
  reply(res, 202, {{"id", *id}, {"kind", body["kind"]}, {"status", "queued"}});
}

// GET /v1/calibrations: the store's versions, the current one, and the
// calibrations asked of this psrigd since it started.
void HttpApi::Impl::calibrations(httplib::Response& res) {
  const config::RigConfig config = service.config();
  const calibration::CalibrationStore store(config.storage.root);
  json versions = json::array();
  for (const auto& version : store.versions()) {
    const fs::path file = version / calibration::kCalibrationFile;
    std::ifstream in(file);
    const json document = json::parse(in, nullptr, false);
    const bool readable = document.is_object();
    versions.push_back({{"version", version.filename().string()},
                        {"created", readable ? document.value("created", json()) : json()},
                        {"contains", readable ? document.value("contains", json()) : json()},
                        {"file", file.string()}});
  }
  reply(res, 200,
        {{"versions", versions},
         {"current", calibration::to_json(
                         calibration::calibration_status(store, config.calibration.max_age_days))},
         {"jobs", service.calibrations().to_json()}});
}

// GET /v1/calibrations/current: the current calibration.json, with its
// version and staleness; 404 when the rig has none.
void HttpApi::Impl::current_calibration(httplib::Response& res) {
  const config::RigConfig config = service.config();
  const calibration::CalibrationStore store(config.storage.root);
  const auto status = calibration::calibration_status(store, config.calibration.max_age_days);
  if (status.missing)
    return refuse(res, 404,
                  status.problem.empty()
                      ? "the rig has no calibration: POST /v1/calibrations {\"kind\": \"lights\"}"
                      : status.problem);
  std::ifstream in(status.file);
  const json document = json::parse(in, nullptr, false);
  reply(res, 200, {{"status", calibration::to_json(status)}, {"calibration", document}});
}

void HttpApi::Impl::status(httplib::Response& res) {
  reply(res, 200, status_json(service));
}

void HttpApi::Impl::submit(const std::string& text, httplib::Response& res) {
  // No body at all: a scan with the defaults.
  const json body = text.empty() ? json::object() : json::parse(text, nullptr, false);
  if (body.is_discarded()) return refuse(res, 400, "malformed JSON in the request body");
  if (!body.is_object()) return refuse(res, 400, "expected a JSON object");
  for (const auto& [key, value] : body.items())
    if (key != "sample_id" && key != "description" && key != "tags" && key != "rig")
      return refuse(res, 400, key + ": unknown field (expected sample_id, description, tags, rig)");
  catalogue::ScanSubmission submission;
  submission.source = "http";
  if (auto problem = string_field(body, "sample_id", kMaxSampleId, submission.sample_id))
    return refuse(res, 400, *problem);
  if (auto problem = string_field(body, "description", kMaxDescription, submission.description))
    return refuse(res, 400, *problem);
  if (body.contains("tags")) {
    const auto& tags = body["tags"];
    if (!tags.is_array()) return refuse(res, 400, "tags: expected an array of strings");
    if (tags.size() > kMaxTags)
      return refuse(res, 400, "tags: more than " + std::to_string(kMaxTags));
    for (const auto& tag : tags) {
      if (!tag.is_string() || tag.get<std::string>().empty())
        return refuse(res, 400, "tags: expected an array of non-empty strings");
      if (tag.get<std::string>().size() > kMaxTag)
        return refuse(res, 400, "tags: a tag longer than " + std::to_string(kMaxTag) + " bytes");
      submission.tags.push_back(tag.get<std::string>());
    }
  }
  // Another rig of the shared catalogue: its own psrigd takes the scan.
  std::string rig;
  if (auto problem = string_field(body, "rig", kMaxSampleId, rig)) return refuse(res, 400, *problem);
  if (body.contains("rig") && (!service.has_rig() || rig != service.catalogue().rig_name())) {
    if (!config::is_shared_catalogue(service.config().catalogue))
      return refuse(res, 404,
                    "rig: this psrigd's catalogue is its own (SQLite); it knows only rig \"" +
                        service.catalogue().rig_name() + "\"");
    json forwarded = body;
    forwarded.erase("rig");
    return forward(rig, "POST", kScansRoute, forwarded.dump(), res);
  }
  auto id = service.submit(std::move(submission));
  if (!id) {
    // A full queue is the service's state, not the request's fault.
    if (id.error().code == ErrorCode::queue_full) {
      res.set_header("Retry-After", "5");
      return refuse(res, 503, id.error().message);
    }
    if (id.error().kind == ErrorKind::bad_input) return refuse(res, 400, id.error().message);
    // The daemon's trouble (a full disk, the database away): which, for the technician.
    res.set_header("Retry-After", "5");
    return refuse(res, 503, id.error().describe());
  }
  res.set_header("Location", "/v1/scans/" + std::to_string(*id));
  reply(res, 202, {{"id", *id}, {"status", "queued"}, {"rig", service.catalogue().rig_name()}});
}

namespace {

// "wales_min" -> (wales_per_cm, false), "picks_max" -> (picks_per_cm, true).
std::optional<std::pair<std::string, bool>> fabric_range_parameter(const std::string& key) {
  for (const char* column : catalogue::CatalogueQuery::kFabricColumns) {
    const std::string name(column);
    const std::string stem = name.substr(0, name.find('_'));
    if (key == stem + "_min") return std::pair{name, false};
    if (key == stem + "_max") return std::pair{name, true};
  }
  return std::nullopt;
}

}  // namespace

void HttpApi::Impl::search(const httplib::Request& req, httplib::Response& res) {
  catalogue::CatalogueQuery query;
  for (const auto& [key, value] : req.params) {
    if (key == "q") {
      if (!value.empty()) query.text = value;
    } else if (key == "sample_id") {
      query.sample_id = value;
    } else if (key == "tag") {
      query.tag = value;
    } else if (key == "rig") {
      query.rig = value;
    } else if (key == "from" || key == "to") {
      auto normal = catalogue::normalise_timestamp(value, key == "to");
      if (!normal)
        return refuse(res, 400,
                      key +
                          ": expected a real UTC date or date-time, e.g. 2026-05-04 or "
                          "2026-05-04T09:00:00Z");
      (key == "from" ? query.from : query.to) = *normal;
    } else if (key == "status") {
      query.status = catalogue::parse_scan_status(value);
      if (!query.status)
        return refuse(res, 400, "status: expected queued, running, done, failed or aborted");
    } else if (key == "limit" || key == "offset") {
      int number = 0;
      const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), number);
      const int low = key == "limit" ? 1 : 0;
      const int high = key == "limit" ? kMaxSearchLimit : std::numeric_limits<int>::max();
      if (ec != std::errc() || end != value.data() + value.size() || number < low || number > high)
        return refuse(res, 400,
                      key + ": expected a whole number from " + std::to_string(low) +
                          (key == "limit" ? " to " + std::to_string(high) : ""));
      (key == "limit" ? query.limit : query.offset) = number;
    } else if (const auto range = fabric_range_parameter(key)) {
      // wales_min=6&wales_max=8: a measured density per cm within a range.
      double number = 0;
      const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), number);
      if (ec != std::errc() || end != value.data() + value.size() || !std::isfinite(number))
        return refuse(res, 400, key + ": expected a number of threads per cm, e.g. 6.5");
      auto& ranges = query.fabric;
      auto it = std::find_if(ranges.begin(), ranges.end(),
                             [&](const auto& r) { return r.column == range->first; });
      if (it == ranges.end()) it = ranges.insert(ranges.end(), {range->first, {}, {}});
      (range->second ? it->max : it->min) = number;
    } else {
      return refuse(res, 400,
                    key +
                        ": unknown parameter (expected q, sample_id, tag, rig, from, to, status, limit, "
                        "offset, wales_min, wales_max, courses_min, courses_max, ends_min, "
                        "ends_max, picks_min, picks_max)");
    }
  }
  auto found = service.catalogue().search(query);
  if (!found) return catalogue_failure(res, found.error());
  auto total = service.catalogue().count(query);
  if (!total) return catalogue_failure(res, total.error());
  json scans = json::array();
  for (const auto& entry : *found)
    scans.push_back(entry_json(entry));
  reply(res, 200,
        {{"scans", scans}, {"total", *total}, {"limit", query.limit}, {"offset", query.offset}});
}

void HttpApi::Impl::get(const httplib::Request& req, httplib::Response& res) {
  const auto id = parse_id(req.matches[1]);
  if (!id) return refuse(res, 404, "no such scan");
  auto entry = service.catalogue().get(*id);
  if (!entry) return catalogue_failure(res, entry.error());
  if (!*entry) return refuse(res, 404, "no scan " + std::to_string(*id));
  reply(res, 200, entry_json(**entry));
}

void HttpApi::Impl::file(const httplib::Request& req, httplib::Response& res) {
  const auto id = parse_id(req.matches[1]);
  if (!id) return refuse(res, 404, "no such scan");
  // The name only picks from a fixed list; the path is ours.
  const std::string name = req.matches[2];
  const auto home = scan_file_home(name);
  if (!home)
    return refuse(res, 404,
                  "no file named that; ask for scan.json, dark.png, led<k>.png, a map "
                  "(albedo.png, normal.png, height.png, ...) or report.json");
  auto entry = service.catalogue().get(*id);
  if (!entry) return catalogue_failure(res, entry.error());
  if (!*entry) return refuse(res, 404, "no scan " + std::to_string(*id));
  const fs::path& directory =
      *home == ScanFileHome::scan ? (*entry)->scan_directory : (*entry)->maps_directory;
  if (directory.empty()) return refuse(res, 404, "scan " + std::to_string(*id) + " has no " + name);
  send_file(req, res, directory / name, content_type(name),
            "scan " + std::to_string(*id) + " has no " + name);
}

void HttpApi::Impl::preview(const httplib::Request& req, httplib::Response& res) {
  const auto id = parse_id(req.matches[1]);
  if (!id) return refuse(res, 404, "no such scan");
  const auto kind = req.matches[2] == "relit" ? ScanPreview::relit : ScanPreview::thumbnail;
  auto entry = service.catalogue().get(*id);
  if (!entry) return catalogue_failure(res, entry.error());
  if (!*entry) return refuse(res, 404, "no scan " + std::to_string(*id));
  if ((*entry)->maps_directory.empty())
    return refuse(res, 404, "scan " + std::to_string(*id) + " has no maps yet");
  auto file = scan_preview((*entry)->maps_directory, kind);
  if (!file)
    return refuse(res, file.error().kind == ErrorKind::bad_input ? 404 : 500,
                  file.error().describe());
  send_file(req, res, *file, "image/png",
            "scan " + std::to_string(*id) + " has no " + file_name(kind));
}

void HttpApi::Impl::remove(const httplib::Request& req, httplib::Response& res) {
  const auto id = parse_id(req.matches[1]);
  if (!id) return refuse(res, 404, "no such scan");
  if (auto entry = service.catalogue().get(*id); entry && *entry && belongs_elsewhere(**entry))
    return forward((*entry)->rig, "DELETE", req.path, "", res);
  auto removed = service.remove(*id);
  if (!removed) return catalogue_failure(res, removed.error());
  switch (*removed) {
    case ScanRemoval::not_found:
      return refuse(res, 404, "no scan " + std::to_string(*id));
    case ScanRemoval::cancelled:
      return reply(res, 200, {{"id", *id}, {"status", "aborted"}});
    case ScanRemoval::aborting:
      return reply(res, 202, {{"id", *id}, {"status", "aborting"}});
    case ScanRemoval::deleted:
      return reply(res, 200, {{"id", *id}, {"deleted", true}});
  }
}

// Stops a scan that has not finished, and never deletes one that has: what
// a client that gives up waiting (psrig scan --remote on Ctrl-C) wants,
// decided in one step so a scan finishing meanwhile is kept.
void HttpApi::Impl::cancel(const httplib::Request& req, httplib::Response& res) {
  const auto id = parse_id(req.matches[1]);
  if (!id) return refuse(res, 404, "no such scan");
  if (auto entry = service.catalogue().get(*id); entry && *entry && belongs_elsewhere(**entry))
    return forward((*entry)->rig, "POST", req.path, "", res);
  auto cancelled = service.cancel(*id);
  if (!cancelled) return catalogue_failure(res, cancelled.error());
  switch (*cancelled) {
    case ScanCancel::not_found:
      return refuse(res, 404, "no scan " + std::to_string(*id));
    case ScanCancel::cancelled:
      return reply(res, 200, {{"id", *id}, {"status", "aborted"}});
    case ScanCancel::aborting:
      return reply(res, 202, {{"id", *id}, {"status", "aborting"}});
    case ScanCancel::already_finished:
      return refuse(res, 409, "scan " + std::to_string(*id) + " has already finished; it is kept");
  }
}

void HttpApi::Impl::events(const httplib::Request& req, httplib::Response& res) {
  // Counted from here; the count drops when the last copy of the stream's
  // state goes, however the stream ends.
  struct Stream {
    std::atomic<int>& count;
    std::uint64_t cursor = 0;
    bool greeted = false;
    std::chrono::steady_clock::time_point last_write = std::chrono::steady_clock::now();
    explicit Stream(std::atomic<int>& c) : count(c) { ++count; }
    ~Stream() { --count; }
    Stream(const Stream&) = delete;
    Stream& operator=(const Stream&) = delete;
  };
  if (event_streams.load() >= options.max_event_streams)
    return refuse(res, 503, "too many event streams open; close one");
  auto stream = std::make_shared<Stream>(event_streams);
  // A listener that reconnects gets what it missed, if still held.
  stream->cursor = service.events().last_sequence();
  if (req.has_header("Last-Event-ID")) {
    std::uint64_t last = 0;
    const std::string text = req.get_header_value("Last-Event-ID");
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), last);
    if (ec == std::errc() && end == text.data() + text.size() && last <= stream->cursor)
      stream->cursor = last;
  }
  res.set_header("Cache-Control", "no-cache");
  res.set_header("X-Accel-Buffering", "no");
  res.set_chunked_content_provider(
      "text/event-stream", [this, stream](std::size_t, httplib::DataSink& sink) {
        try {
          const auto write = [&](const std::string& text) {
            stream->last_write = std::chrono::steady_clock::now();
            return sink.write(text.data(), text.size());
          };
          if (!stream->greeted) {
            stream->greeted = true;
            return write("retry: 2000\n: connected\n\n");
          }
          if (stopping || service.events().closed()) {
            sink.done();  // shutdown must not wait for listeners
            return true;
          }
          for (const auto& event : service.events().wait_after(stream->cursor, kEventPoll)) {
            stream->cursor = event.sequence;
            if (!write("id: " + std::to_string(event.sequence) + "\nevent: " + event.type +
                       "\ndata: " + to_text(event.data) + "\n\n"))
              return false;
          }
          if (std::chrono::steady_clock::now() - stream->last_write > kHeartbeat)
            return write(": heartbeat\n\n");
          return sink.is_writable();
        } catch (const std::exception& e) {
          // As for downloads: an exception here would end the daemon.
          logger("http")->error("event stream: {}", e.what());
          return false;
        }
      });
}

void HttpApi::Impl::lights_off(httplib::Response& res) {
  if (!service.has_rig()) return refuse(res, 409, service.no_rig_error().message);
  if (auto ok = service.lights_off(); !ok)
    return refuse(res, 500, "turning the LEDs off failed: " + ok.error().describe());
  reply(res, 200, {{"lights", "off"}});
}

HttpApi::HttpApi(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

HttpApi::~HttpApi() {
  stop();
}

Result<std::unique_ptr<HttpApi>> HttpApi::start(ScanService& service, HttpApiOptions options) {
  const std::string where = options.address + ":" + std::to_string(options.port);
  if (options.token.empty() && !config::is_loopback_address(options.address))
    return std::unexpected(bad_input(
        service.config().source, "daemon.token",
        "listening on " + where + " reaches other machines; set a token or listen on 127.0.0.1"));
  auto impl = std::make_unique<Impl>(service, options);
  auto& server = impl->server;
  server.set_payload_max_length(options.max_body_bytes);
  impl->routes();
  // Port 0: one the kernel picks (tests, benchmarks); port() says which.
  const int port = options.port == 0
                       ? server.bind_to_any_port(options.address)
                       : (server.bind_to_port(options.address, options.port) ? options.port : -1);
  if (port <= 0)
    return std::unexpected(
        io_error(where, "cannot listen (address in use, or not one of this machine's)"));
  impl->port = port;
  impl->listener = std::thread([&server] { server.listen_after_bind(); });
  // Until it runs, httplib's stop() would not stop it.
  for (int waited = 0; !server.is_running() && waited < 2000; ++waited)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  logger("http")->info("HTTP API on http://{}/v1/ ({})", where,
                       options.token.empty() ? "no token" : "bearer token required");
  return std::unique_ptr<HttpApi>(new HttpApi(std::move(impl)));
}

void HttpApi::stop() {
  if (!impl_ || impl_->stopping.exchange(true)) return;
  impl_->server.stop();
  if (impl_->listener.joinable()) impl_->listener.join();
  impl_->server.stop_serving();
}

int HttpApi::port() const {
  return impl_->port;
}

}  // namespace psrig::daemon
