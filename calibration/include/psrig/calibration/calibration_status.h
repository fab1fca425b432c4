#pragma once
// How current a rig's calibration is: which version, when it was made, how
// old it is against rig.toml's [calibration] max_age_days, which sections
// it holds. What psrig scan warns about, psrig config check says, and
// psrigd's GET /v1/status reports as "calibration".

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "psrig/calibration/calibration_store.h"

namespace psrig::calibration {

struct CalibrationStatus {
  bool missing = true;  // no version in the store (or none readable)
  std::string version;  // "0003"
  std::filesystem::path file;
  std::string created;  // its "created", UTC ISO-8601
  std::optional<double> age_days;
  int max_age_days = 0;               // 0: never stale
  bool stale = false;                 // older than max_age_days
  std::vector<std::string> sections;  // "lights", "flat", "colour", "scale", "led_positions_mm"
  std::string problem;                // why the current version cannot be read, when it cannot
};

// The store's current version as of `now`.
[[nodiscard]] CalibrationStatus calibration_status(
    const CalibrationStore& store, int max_age_days,
    std::chrono::system_clock::time_point now = std::chrono::system_clock::now());

// As psrigd's status gives it: {"version", "file", "created", "age_days",
// "max_age_days", "stale", "missing", "sections"}.
[[nodiscard]] nlohmann::json to_json(const CalibrationStatus& status);

// One line for people: what is wrong and the fix, or empty when current.
[[nodiscard]] std::string staleness_warning(const CalibrationStatus& status);

// "2026-01-31T12:00:00Z" as a time; nullopt when not in that form.
[[nodiscard]] std::optional<std::chrono::system_clock::time_point> parse_utc(
    const std::string& text);

}  // namespace psrig::calibration
