#pragma once
// psrigd's HTTP/JSON API (cpp-httplib), on 127.0.0.1:8470 by default:
//
//   GET    /v1/status                   state, step, progress, devices, last error, uptime, queue
//   POST   /v1/scans                    {sample_id, description, tags} -> 202 {id}
//   GET    /v1/scans                    ?sample_id= &tag= &from= &to= &status= &limit= &offset=
//   GET    /v1/scans/{id}               metadata, status, report
//   GET    /v1/scans/{id}/files/{name}  a frame, scan.json, a map or report.json, by name
//   DELETE /v1/scans/{id}               cancel (queued), abort (running) or delete (finished)
//   GET    /v1/events                   server-sent events: progress, done, error
//   POST   /v1/lights/off               aborts the running scan, every LED off
//
// Every error is a 4xx/5xx with {"error": "..."}. With a token configured,
// every request needs "Authorization: Bearer TOKEN"; off loopback a token
// is required to start at all.

#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>

#include "psrig/config/rig_config.h"
#include "psrig/daemon/scan_service.h"

namespace psrig::daemon {

struct HttpApiOptions {
  std::string address = "127.0.0.1";
  int port = 8470;  // 0: any free port (HttpApi::port() says which)
  std::string token;  // empty: no authentication (loopback only)
  std::size_t max_body_bytes = 64 * 1024;
  int threads = 8;  // general requests served at once, event streams included (lights-off
                    // and status have threads of their own: fronted_server.h)
  int max_event_streams = 4;  // so that listeners cannot take every thread
  std::filesystem::path web_root;  // the web catalogue's files; empty: not served
};

[[nodiscard]] HttpApiOptions http_api_options(const config::DaemonConfig& daemon);

// The names GET /v1/scans/{id}/files/{name} serves (nothing else, and
// never a path from the request), and the directory each lives in.
enum class ScanFileHome { scan, maps };
[[nodiscard]] std::optional<ScanFileHome> scan_file_home(const std::string& name);

// Equal strings, compared in a time that does not depend on where they differ.
[[nodiscard]] bool constant_time_equal(const std::string& a, const std::string& b);

class HttpApi {
 public:
  // Binds the address (an error names it when taken or not allowed) and
  // serves on threads of its own until stop().
  [[nodiscard]] static Result<std::unique_ptr<HttpApi>> start(ScanService& service,
                                                              HttpApiOptions options);
  ~HttpApi();
  HttpApi(const HttpApi&) = delete;
  HttpApi& operator=(const HttpApi&) = delete;

  // Ends the event streams, stops listening, waits for the requests in
  // progress. Idempotent.
  void stop();
  [[nodiscard]] int port() const;

 private:
  struct Impl;
  explicit HttpApi(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace psrig::daemon
