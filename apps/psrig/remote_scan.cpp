#include "remote_scan.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "command.h"
#include "daemon_client.h"
#include "psrig/formats/scan_layout.h"
#include "psrig/lights/emergency_stop.h"

namespace psrig::cli {
namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

// How often the loop looks at Ctrl-C, and polls psrigd without an event stream.
constexpr auto kPollInterval = 200ms;
// How often the scan's row is read while the event stream works (it is the
// authority on how the scan ended; the stream only says so sooner).
constexpr auto kRecordInterval = 1s;
// Once the row says the scan has finished, how long its last events may
// take to arrive before the summary is printed without them.
constexpr auto kStreamGrace = 2s;

// psrigd's event stream, followed on a connection of its own by a thread
// of its own, reconnecting (Last-Event-ID) if it breaks.
class EventFollower {
 public:
  // Returns once the stream is open (every event published from then on
  // will come) or could not be opened (why()).
  EventFollower(const std::string& url, const std::string& token) : client_(url, token) {
    thread_ = std::thread([this] { run(); });
    std::unique_lock lock(mutex_);
    changed_.wait_for(lock, 10s, [&] { return opened_ || why_; });
  }
  ~EventFollower() {
    stopping_ = true;
    changed_.notify_all();
    // stop() ends a request in progress; one just starting is ended on the next pass.
    while (!finished_) {
      client_.stop();
      std::this_thread::sleep_for(20ms);
    }
    thread_.join();
  }
  EventFollower(const EventFollower&) = delete;
  EventFollower& operator=(const EventFollower&) = delete;

  [[nodiscard]] bool open() const {
    std::lock_guard lock(mutex_);
    return opened_;
  }
  // Why the stream could not be opened, once it could not.
  [[nodiscard]] std::optional<std::string> why() const {
    std::lock_guard lock(mutex_);
    return why_;
  }

  // The events received since the last call, waiting at most `timeout` for one.
  std::vector<DaemonEvent> take(Clock::duration timeout) {
    std::unique_lock lock(mutex_);
    changed_.wait_for(lock, timeout, [&] { return !events_.empty() || stopping_; });
    std::vector<DaemonEvent> taken(std::make_move_iterator(events_.begin()),
                                   std::make_move_iterator(events_.end()));
    events_.clear();
    return taken;
  }

 private:
  void run() {
    std::uint64_t last = 0;
    while (!stopping_) {
      auto ended = client_.follow_events(
          last,
          [&] {
            std::lock_guard lock(mutex_);
            opened_ = true;
            changed_.notify_all();
          },
          [&](DaemonEvent event) {
            if (stopping_) return false;
            last = std::max(last, event.sequence);
            std::lock_guard lock(mutex_);
            events_.push_back(std::move(event));
            changed_.notify_all();
            return true;
          });
      if (stopping_) break;
      {
        std::lock_guard lock(mutex_);
        if (!opened_) {  // never opened: the caller polls instead
          why_ = ended ? std::string("it ended at once") : ended.error().describe();
          changed_.notify_all();
          break;
        }
      }
      // It broke (psrigd restarting, a network hiccup): again, from the last event seen.
      for (int i = 0; i < 25 && !stopping_; ++i)
        std::this_thread::sleep_for(20ms);
    }
    finished_ = true;
  }

  DaemonClient client_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<DaemonEvent> events_;
  bool opened_ = false;
  std::optional<std::string> why_;
  std::atomic<bool> stopping_{false};
  std::atomic<bool> finished_{false};
  std::thread thread_;
};

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

// A JSON file of the scan, through GET /v1/scans/{id}/files/{name}; null if
// psrigd has none.
nlohmann::json scan_file(DaemonClient& client, const std::string& path, const std::string& name) {
  auto reply = client.get(path + "/files/" + name);
  if (!reply || reply->status != 200) return nullptr;
  return std::move(reply->body);
}

// The summary `psrig scan` prints, from a done scan's row: its report (or
// report.json) for the maps, and the report's copy of scan.json's capture
// facts (or scan.json) for the frames.
ScanSummary remote_summary(DaemonClient& client, const std::string& path,
                           const nlohmann::json& entry) {
  ScanSummary summary;
  summary.directory = reply_text(entry["scan_directory"]);
  nlohmann::json report = entry["report"];
  if (entry["maps_directory"].is_string()) {
    if (!report.is_object()) report = scan_file(client, path, formats::map_files::kReport);
    if (report.is_object())
      summary.maps = processing::ProcessSummary{entry["maps_directory"].get<std::string>(), report};
  }
  const nlohmann::json::json_pointer capture("/inputs/capture");
  if (report.is_object() && report.contains(capture)) {
    add_capture_facts(summary, report.at(capture));
  } else if (const auto description = scan_file(client, path, formats::scan_files::kDescription);
             description.is_object() && description.contains("capture")) {
    add_capture_facts(summary, description["capture"]);
  }
  return summary;
}

}  // namespace

int run_remote_scan(const RemoteScan& scan) {
  if (auto url = check_daemon_url(scan.url, "--remote"); !url)
    return report_error("scan", url.error());
  DaemonClient client(scan.url, scan.token);
  // Listening before the scan is queued, so none of its events is missed.
  EventFollower events(scan.url, scan.token);
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
  const bool streaming = events.open();
  if (!scan.quiet) {
    std::fprintf(stderr, "psrig scan: scan %lld queued on %s\n", static_cast<long long>(id),
                 scan.url.c_str());
    if (!streaming)
      std::fprintf(stderr,
                   "psrig scan: warning: cannot follow psrigd's events (%s); steps shorter "
                   "than %lld ms may not be shown\n",
                   events.why().value_or("?").c_str(),
                   static_cast<long long>(kPollInterval.count()));
  }

  // Each step as `psrig scan` shows it on the rig here.
  std::string last_step;
  const auto show = [&](const std::string& step) {
    if (scan.quiet || step.empty() || step == last_step) return;
    std::fprintf(stderr, "psrig scan: %s\n", step.c_str());
    last_step = step;
  };
  bool ended_in_stream = false;
  auto next_record = Clock::now();
  std::optional<Clock::time_point> finished_at;
  for (;;) {
    if (lights::stop_requested()) {
      std::fprintf(stderr, "psrig scan: interrupted; scan %lld %s\n", static_cast<long long>(id),
                   cancel(client, path).c_str());
      return psrig::cli::exit_interrupted;
    }
    for (const auto& event : events.take(kPollInterval)) {
      if (!event.data.is_object() || event.data.value("id", std::int64_t{-1}) != id) continue;
      if (event.type == "progress")
        show(reply_text(event.data["step"]));
      else if (event.type == "done" || event.type == "error")
        ended_in_stream = true;
    }
    if (!streaming && !scan.quiet) {
      auto daemon = client.get("/v1/status");
      if (daemon && daemon->status == 200 && daemon->body["current_scan"] == id)
        show(reply_text(daemon->body["step"]));
    }
    const auto now = Clock::now();
    if (!ended_in_stream && now < next_record) continue;
    next_record = now + (streaming ? kRecordInterval : kPollInterval);
    auto entry = client.get(path);
    if (!entry) return report_error("scan", entry.error());
    if (entry->status != 200)
      return report_error(
          "scan", io_error(scan.url, "scan " + std::to_string(id) + ": " + reply_error(*entry)));
    const std::string status = reply_text(entry->body["status"]);
    if (status == "queued" || status == "running") continue;
    // Finished: its last steps are on their way in the stream, if it works.
    if (!finished_at) finished_at = now;
    if (streaming && !ended_in_stream && now - *finished_at < kStreamGrace) continue;

    if (status == "done") {
      if (scan.quiet) return 0;
      std::fprintf(stderr, "psrig scan: scan %lld done\n", static_cast<long long>(id));
      try {
        print_scan_summary(remote_summary(client, path, entry->body));
      } catch (const nlohmann::json::exception& e) {
        return report_error(
            "scan", io_error(scan.url, "scan " + std::to_string(id) +
                                           ": a report this psrig cannot read (" + e.what() + ")"));
      }
      return 0;
    }
    const auto& error = entry->body["error"];
    std::fprintf(stderr, "psrig scan: error: scan %lld %s (%s): %s\n", static_cast<long long>(id),
                 status.c_str(), error.is_object() ? reply_text(error["code_name"]).c_str() : "?",
                 error.is_object() ? reply_text(error["message"]).c_str() : "");
    return 1;
  }
}

}  // namespace psrig::cli
