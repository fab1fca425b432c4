#pragma once
// The whole chain for one scan: read -> linearise -> solve -> integrate ->
// evaluate -> maps directory, with the report of what happened.

#include <filesystem>
#include <optional>
#include <string_view>

#include <nlohmann/json.hpp>

#include "psrig/base/error.h"
#include "psrig/formats/scan.h"
#include "psrig/formats/storage_options.h"
#include "psrig/processing/flatten.h"
#include "psrig/processing/integration.h"
#include "psrig/processing/woodham.h"

namespace psrig::processing {

inline constexpr const char* kReportFormat = "psrig-report/1";

// Removing the low-frequency bend (flatten.h) after integration:
// automatic does it for swatch scans, those whose scan.json gives
// pixel_size_mm (the rig's and psrig synth's), and not for objects measured
// in pixels.
enum class Flatten { automatic, on, off };
// "auto" | "on" | "off".
[[nodiscard]] std::optional<Flatten> parse_flatten(std::string_view name);
[[nodiscard]] std::string_view to_string(Flatten flatten);

struct ProcessOptions {
  std::filesystem::path output;  // empty: SCAN_DIR/maps
  // automatic: the masked least-squares solver when some pixels are not
  // solved (the scan's mask, holes, dark or unsolvable pixels), over the
  // solved ones; Frankot–Chellappa when every pixel is.
  IntegrationMethod integration = IntegrationMethod::automatic;
  Flatten flatten = Flatten::automatic;
  // The bend's cut-off wavelength: millimetres, or pixels for a scan
  // without pixel_size_mm.
  double flatten_cutoff_mm = kDefaultFlattenCutoffMm;
  // normal.png is always OpenGL's convention (+Y up: glTF, U3M, the
  // preview); directx adds normal_directx.png (+Y down) beside it.
  bool directx_normal = false;
  SolveOptions solve;
  formats::StorageOptions storage;  // the maps' lossless compression
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
// The same for a scan already in memory as it is stored in `scan_directory`
// (formats::as_stored): its frames are not read back from the disk.
[[nodiscard]] Result<ProcessSummary> process_scan(formats::Scan scan,
                                                  const std::filesystem::path& scan_directory,
                                                  const ProcessOptions& options = {});

}  // namespace psrig::processing
