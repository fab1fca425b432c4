#pragma once
// The whole chain for one scan: read -> linearise -> solve -> integrate ->
// evaluate -> maps directory, with the report of what happened.

#include <filesystem>

#include <nlohmann/json.hpp>

#include "psrig/base/error.h"
#include "psrig/processing/integration.h"
#include "psrig/processing/woodham.h"

namespace psrig::processing {

inline constexpr const char* kReportFormat = "psrig-report/1";

struct ProcessOptions {
  std::filesystem::path output;  // empty: SCAN_DIR/maps
  IntegrationMethod integration = IntegrationMethod::frankot_chellappa;
  SolveOptions solve;
};

struct ProcessSummary {
  std::filesystem::path maps_directory;
  nlohmann::json report;  // as written to report.json
};

// Processes the scan directory into a maps directory that appears whole or
// not at all: on any error, nothing is left behind. An existing maps
// directory (one holding a psrig report) is replaced; any other existing
// path is refused.
[[nodiscard]] Result<ProcessSummary> process_scan(const std::filesystem::path& scan_directory,
                                                  const ProcessOptions& options = {});

}  // namespace psrig::processing
