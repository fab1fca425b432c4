#include "psrig/daemon/calibration_jobs.h"

#include <algorithm>

#include "psrig/calibration/calibration_store.h"

namespace psrig::daemon {

namespace {
constexpr std::size_t kKept = 100;
}

CalibrationJob CalibrationJobs::add(const nlohmann::json& options,
                                    rig::CalibrationRequest request) {
  std::lock_guard lock(mutex_);
  CalibrationJob job;
  job.id = next_++;
  job.kind = request.kind;
  job.options = options;
  job.request = std::move(request);
  job.queued = calibration::utc_now();
  jobs_.push_back(job);
  // Only finished ones are forgotten: a queued or running job stays.
  while (jobs_.size() > kKept && jobs_.front().status != "queued" &&
         jobs_.front().status != "running")
    jobs_.pop_front();
  return job;
}

CalibrationJob* CalibrationJobs::find(std::int64_t id) {
  const auto it =
      std::find_if(jobs_.begin(), jobs_.end(), [&](const CalibrationJob& j) { return j.id == id; });
  return it == jobs_.end() ? nullptr : &*it;
}

void CalibrationJobs::forget(std::int64_t id) {
  std::lock_guard lock(mutex_);
  std::erase_if(jobs_, [&](const CalibrationJob& j) { return j.id == id; });
}

void CalibrationJobs::started(std::int64_t id, std::int64_t scans_finished_before) {
  std::lock_guard lock(mutex_);
  if (auto* job = find(id)) {
    job->status = "running";
    job->started = calibration::utc_now();
    job->scans_finished_before = scans_finished_before;
  }
}

void CalibrationJobs::step(std::int64_t id, const std::string& step) {
  std::lock_guard lock(mutex_);
  if (auto* job = find(id)) job->step = step;
}

void CalibrationJobs::ended(std::int64_t id, const std::string& status, const std::string& error,
                            const std::string& version) {
  std::lock_guard lock(mutex_);
  if (auto* job = find(id)) {
    job->status = status;
    job->error = error;
    job->version = version;
    job->step.clear();
    job->finished = calibration::utc_now();
  }
}

std::optional<CalibrationJob> CalibrationJobs::get(std::int64_t id) const {
  std::lock_guard lock(mutex_);
  for (const auto& job : jobs_)
    if (job.id == id) return job;
  return std::nullopt;
}

nlohmann::json to_json(const CalibrationJob& job) {
  using nlohmann::json;
  const auto or_null = [](const std::string& text) { return text.empty() ? json() : json(text); };
  return {{"id", job.id},
          {"kind", job.kind},
          {"options", job.options},
          {"status", job.status},
          {"queued", or_null(job.queued)},
          {"started", or_null(job.started)},
          {"finished", or_null(job.finished)},
          {"step", or_null(job.step)},
          {"error", or_null(job.error)},
          {"version", or_null(job.version)},
          {"scans_finished_before", job.scans_finished_before}};
}

nlohmann::json CalibrationJobs::to_json() const {
  std::lock_guard lock(mutex_);
  nlohmann::json list = nlohmann::json::array();
  for (auto it = jobs_.rbegin(); it != jobs_.rend(); ++it)
    list.push_back(daemon::to_json(*it));
  return list;
}

}  // namespace psrig::daemon
