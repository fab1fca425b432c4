#include "remote_scan.h"

#include <chrono>
#include <cstdio>
#include <optional>
#include <thread>

#include "command.h"
#include "daemon_client.h"
#include "psrig/firmware_host/emergency_stop.h"

namespace psrig::capture::cli {
namespace {

// Often enough to show each light's step, rarely enough not to matter.
constexpr auto kPollInterval = std::chrono::milliseconds(200);

// Gives up on the scan at `path`: cancelled if queued, aborted if running,
// never deleted (a scan that finished between two polls is kept). What
// happened, for the message.
std::string cancel(DaemonClient& client, const std::string& path) {
  const auto reply = client.post(path + "/cancel", nlohmann::json::object());
  if (!reply) return "may still run on psrigd (" + reply.error().describe() + ")";
  if (reply->status == 409) return "had already finished on psrigd; kept";
  if (reply->status == 200) return "cancelled on psrigd";
  if (reply->status == 202) return "aborting on psrigd (LEDs off)";
  return "may still run on psrigd (" + reply_error(*reply) + ")";
}

// A number of the reply, if it is one (a NaN metric is written as null).
std::optional<double> number(const nlohmann::json& value) {
  if (!value.is_number()) return std::nullopt;
  return value.get<double>();
}

}  // namespace

int run_remote_scan(const RemoteScan& scan) {
  if (auto url = check_daemon_url(scan.url, "--remote"); !url)
    return report_error("scan", url.error());
  DaemonClient client(scan.url, scan.token);
  auto queued = client.post(
      "/v1/scans",
      {{"sample_id", scan.sample_id}, {"description", scan.description}, {"tags", scan.tags}});
  if (!queued) return report_error("scan", queued.error());
  if (queued->status != 202) {
    // 4xx: the request (sample id, tags, token); anything else: the daemon.
    const std::string message = "psrigd refused the scan: " + reply_error(*queued);
    const bool ours = queued->status >= 400 && queued->status < 500;
    const auto error = ours ? bad_input(scan.url, "", message) : io_error(scan.url, message);
    return report_error("scan", error);
  }
  if (!queued->body.is_object() || !queued->body["id"].is_number_integer())
    return report_error("scan", io_error(scan.url,
                                         "psrigd queued the scan but gave "
                                         "no id: " +
                                             queued->body.dump()));
  const auto id = queued->body["id"].get<std::int64_t>();
  const std::string path = "/v1/scans/" + std::to_string(id);
  if (!scan.quiet)
    std::fprintf(stderr, "psrig scan: scan %lld queued on %s\n", static_cast<long long>(id),
                 scan.url.c_str());

  std::string last_step;
  for (;;) {
    if (firmware_host::stop_requested()) {
      std::fprintf(stderr, "psrig scan: interrupted; scan %lld %s\n", static_cast<long long>(id),
                   cancel(client, path).c_str());
      return psrig::cli::exit_interrupted;
    }
    auto entry = client.get(path);
    if (!entry) return report_error("scan", entry.error());
    if (entry->status != 200)
      return report_error(
          "scan", io_error(scan.url, "scan " + std::to_string(id) + ": " + reply_error(*entry)));
    const std::string status = reply_text(entry->body["status"]);
    if (status == "done") {
      const auto& e = entry->body;
      std::printf("scan %lld: done\n", static_cast<long long>(id));
      std::printf("scan: %s\n", reply_text(e["scan_directory"]).c_str());
      if (!e["maps_directory"].is_null())
        std::printf("maps: %s\n", reply_text(e["maps_directory"]).c_str());
      const auto& report = e["report"];
      using Pointer = nlohmann::json::json_pointer;
      const auto metric = [&](const char* at) -> std::optional<double> {
        if (!report.is_object() || !report.contains(Pointer(at))) return std::nullopt;
        return number(report.at(Pointer(at)));
      };
      if (const auto residual = metric("/residual/mean"))
        std::printf("residual: mean %.5f of full scale\n", *residual);
      if (const auto angular = metric("/ground_truth/angular_error_deg/mean"))
        std::printf("ground truth: mean angular error %.3f deg\n", *angular);
      return 0;
    }
    if (status == "failed" || status == "aborted") {
      const auto& error = entry->body["error"];
      std::fprintf(stderr, "psrig scan: error: scan %lld %s (%s): %s\n", static_cast<long long>(id),
                   status.c_str(), error.is_object() ? reply_text(error["code_name"]).c_str() : "?",
                   error.is_object() ? reply_text(error["message"]).c_str() : "");
      return 1;
    }
    if (!scan.quiet && status == "running") {
      auto daemon = client.get("/v1/status");
      if (daemon && daemon->status == 200 && daemon->body["current_scan"] == id) {
        const std::string step = reply_text(daemon->body["step"]);
        if (!step.empty() && step != last_step)
          std::fprintf(stderr, "psrig scan: %s\n", step.c_str());
        last_step = step;
      }
    }
    std::this_thread::sleep_for(kPollInterval);
  }
}

}  // namespace psrig::capture::cli
