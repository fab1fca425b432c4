#include "psrig/calibration/calibration_status.h"

#include <cmath>
#include <ctime>
#include <fstream>

namespace psrig::calibration {

namespace fs = std::filesystem;

std::optional<std::chrono::system_clock::time_point> parse_utc(const std::string& text) {
  std::tm tm{};
  const char* end = strptime(text.c_str(), "%Y-%m-%dT%H:%M:%SZ", &tm);
  if (!end || *end != '\0') return std::nullopt;
  return std::chrono::system_clock::from_time_t(timegm(&tm));
}

CalibrationStatus calibration_status(const CalibrationStore& store, int max_age_days,
                                     std::chrono::system_clock::time_point now) {
  CalibrationStatus status;
  status.max_age_days = max_age_days;
  const auto file = store.current();
  if (!file) return status;
  status.file = *file;
  status.version = file->parent_path().filename().string();
  // Read as a document only: a version whose lights are unusable is still
  // the current one, and its age still counts.
  std::ifstream in(*file);
  const nlohmann::json document = nlohmann::json::parse(in, nullptr, false);
  if (document.is_discarded() || !document.is_object()) {
    status.problem = file->string() + " is not JSON: run the calibrations again";
    return status;
  }
  status.missing = false;
  for (const char* section : {"lights", "flat", "colour", "scale", "led_positions_mm"})
    if (document.contains(section) && !document[section].is_null())
      status.sections.push_back(section);
  if (document.contains("created") && document["created"].is_string()) {
    status.created = document["created"].get<std::string>();
    if (const auto made = parse_utc(status.created)) {
      const double days = std::chrono::duration<double>(now - *made).count() / 86400.0;
      status.age_days = std::round(days * 100) / 100;
    }
  }
  // An undated calibration is as stale as one can be.
  status.stale = max_age_days > 0 && (!status.age_days || *status.age_days > max_age_days);
  return status;
}

nlohmann::json to_json(const CalibrationStatus& s) {
  using nlohmann::json;
  const auto or_null = [](const std::string& text) { return text.empty() ? json() : json(text); };
  return {{"missing", s.missing},           {"stale", s.stale},
          {"version", or_null(s.version)},  {"file", or_null(s.file.string())},
          {"created", or_null(s.created)},  {"age_days", s.age_days ? json(*s.age_days) : json()},
          {"max_age_days", s.max_age_days}, {"sections", s.sections},
          {"problem", or_null(s.problem)}};
}

std::string staleness_warning(const CalibrationStatus& s) {
  if (s.missing)
    return s.problem.empty()
               ? "the rig has no calibration: light directions come from rig.toml's geometry; "
                 "run psrig calibrate lights (then flat, scale)"
               : "the rig's calibration cannot be read (" + s.problem + ")";
  if (!s.stale) return {};
  if (!s.age_days)
    return "the rig's calibration " + s.version + " has no date: run psrig calibrate lights again";
  char age[32];
  std::snprintf(age, sizeof age, "%.0f", std::floor(*s.age_days));
  return "the rig's calibration " + s.version + " is " + age + " days old (made " + s.created +
         "; [calibration] max_age_days = " + std::to_string(s.max_age_days) +
         "): run psrig calibrate lights (then flat, scale) again";
}

}  // namespace psrig::calibration
