// psrig status [--url URL]: what a running psrigd is doing.

#include <cstdio>
#include <memory>

#include "command.h"
#include "daemon_client.h"

namespace psrig::cli {
namespace {

struct StatusArgs {
  std::string url = kDefaultDaemonUrl;
  std::string token;
  bool json = false;
};

std::string duration_text(double seconds) {
  const auto s = static_cast<long>(seconds);
  char out[64];
  if (s >= 3600)
    std::snprintf(out, sizeof out, "%ld h %02ld min", s / 3600, s % 3600 / 60);
  else if (s >= 60)
    std::snprintf(out, sizeof out, "%ld min %02ld s", s / 60, s % 60);
  else
    std::snprintf(out, sizeof out, "%ld s", s);
  return out;
}

void print_status(const std::string& url, const nlohmann::json& s) {
  std::printf("psrigd at %s: %s\n", url.c_str(), reply_text(s["state"]).c_str());
  if (!s["current_scan"].is_null())
    std::printf("scan %s: %s (%s %%)\n", reply_text(s["current_scan"]).c_str(),
                reply_text(s["step"]).c_str(), reply_text(s["progress_percent"]).c_str());
  std::printf("queue: %s waiting (limit %s)\n", reply_text(s["queue_length"]).c_str(),
              reply_text(s["queue_limit"]).c_str());
  std::printf("scans: %s done, %s failed in %s; last scan %s\n",
              reply_text(s["scans_completed"]).c_str(), reply_text(s["scans_failed"]).c_str(),
              duration_text(s["uptime_s"].get<double>()).c_str(),
              s["last_scan"].is_null() ? "none" : reply_text(s["last_scan"]).c_str());
  const auto& error = s["last_error"];
  if (error["code"].get<int>() != 0)
    std::printf("last error: %s: %s\n", reply_text(error["code_name"]).c_str(),
                reply_text(error["message"]).c_str());
  const auto& devices = s["devices"];
  if (devices["open"].get<bool>())
    std::printf("devices: %s; %s\n", reply_text(devices["lights"]).c_str(),
                reply_text(devices["camera"]).c_str());
  else
    std::printf("devices: not open%s%s\n", reply_text(devices["error"]).empty() ? "" : ": ",
                reply_text(devices["error"]).c_str());
  std::printf("storage: %s\n", reply_text(s["storage_root"]).c_str());
  if (s.contains("calibration") && s["calibration"].is_object()) {
    const auto& c = s["calibration"];
    if (c.value("missing", true)) {
      std::printf("calibration: missing (psrig calibrate lights, flat, scale)\n");
    } else {
      std::string sections;
      for (const auto& section : c["sections"])
        sections += (sections.empty() ? "" : ", ") + section.get<std::string>();
      char age[32] = "undated";
      if (c["age_days"].is_number())
        std::snprintf(age, sizeof age, "%.1f days old", c["age_days"].get<double>());
      std::printf("calibration: %s (%s), %s%s\n", reply_text(c["version"]).c_str(),
                  sections.c_str(), age,
                  c.value("stale", false) ? ", STALE: calibrate the rig again" : "");
    }
  }
}

}  // namespace

Command add_status_command(CLI::App& parent) {
  auto args = std::make_shared<StatusArgs>();
  CLI::App* app = parent.add_subcommand("status", "What a running psrigd is doing");
  app->add_option("--url", args->url, "The daemon's address")->capture_default_str();
  app->add_option("--token", args->token, "Bearer token (default: $PSRIG_TOKEN)");
  app->add_flag("--json", args->json, "Print the daemon's answer as JSON");
  return {app, [args] {
            if (auto url = check_daemon_url(args->url, "--url"); !url)
              return report_error("status", url.error());
            DaemonClient client(args->url, args->token);
            auto reply = client.get("/v1/status");
            if (!reply) return report_error("status", reply.error());
            if (reply->status != 200)
              return report_error("status", io_error(args->url, reply_error(*reply)));
            try {
              if (args->json)
                std::printf("%s\n", reply->body.dump(2).c_str());
              else
                print_status(args->url, reply->body);
            } catch (const nlohmann::json::exception& e) {
              return report_error(
                  "status", io_error(args->url, std::string("unexpected answer: ") + e.what()));
            }
            return 0;
          }};
}

}  // namespace psrig::cli
