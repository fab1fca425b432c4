#pragma once
// The calibrations psrigd was asked to run (POST /v1/calibrations): each
// queued with the scans (it needs the rig, never beside a scan), then
// running, then done (the version it stored) or failed (why). Kept in
// memory for GET /v1/calibrations; the calibrations themselves live in the
// rig's store. Thread-safe.

#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "psrig/rig/rig_calibration.h"

namespace psrig::daemon {

struct CalibrationJob {
  std::int64_t id = 0;  // 1, 2, 3, … (the queue knows it as -id, apart from scans' ids)
  std::string kind;
  nlohmann::json options;                 // as asked
  rig::CalibrationRequest request;        // what runs
  std::string status = "queued";          // queued | running | done | failed | aborted
  std::string queued, started, finished;  // UTC ISO-8601
  std::string step;
  std::string error;
  std::string version;  // the store's version it made, when done
  // Scans finished (done or failed) when it started: that it waited for
  // the one running when it was queued.
  std::int64_t scans_finished_before = 0;
};

class CalibrationJobs {
 public:
  // A new job, queued.
  [[nodiscard]] CalibrationJob add(const nlohmann::json& options, rig::CalibrationRequest request);
  // Forgets a job that the queue refused.
  void forget(std::int64_t id);
  void started(std::int64_t id, std::int64_t scans_finished_before);
  void step(std::int64_t id, const std::string& step);
  void ended(std::int64_t id, const std::string& status, const std::string& error,
             const std::string& version);
  [[nodiscard]] std::optional<CalibrationJob> get(std::int64_t id) const;
  // The newest 100, newest first.
  [[nodiscard]] nlohmann::json to_json() const;

 private:
  CalibrationJob* find(std::int64_t id);
  mutable std::mutex mutex_;
  std::deque<CalibrationJob> jobs_;
  std::int64_t next_ = 1;
};

[[nodiscard]] nlohmann::json to_json(const CalibrationJob& job);

}  // namespace psrig::daemon
