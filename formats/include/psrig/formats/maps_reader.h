#pragma once
// A maps directory read back (docs/design.md "Maps directory"), for the
// steps that work on maps rather than scans: measuring the fabric, cutting
// the seamless tile.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "psrig/base/error.h"

namespace psrig::formats {

struct Maps {
  std::filesystem::path directory;
  cv::Mat albedo;         // CV_32FC3, linear, BGR (albedo.exr)
  cv::Mat p, q;           // CV_32F gradients (p.exr, q.exr): p = dz/dx, q = dz/dy, y up
  cv::Mat height;         // CV_32F (height.exr), NaN where none; empty when the maps have none
  cv::Mat mask;           // CV_8U (mask.png), 255 = valid
  nlohmann::json report;  // report.json, or null when it is missing
  std::optional<double> pixel_size_mm;  // the report's inputs.pixel_size_mm
  std::string height_units = "px";      // "mm" or "px"
  nlohmann::json scan_document;         // the scan's scan.json when the report names it, or null
};

// Reads a maps directory. Missing report.json is not an error (the maps
// are then taken as in pixels); each thing missing that a user may want to
// know about goes into `warnings`. Missing or unreadable maps are bad input
// naming the file.
[[nodiscard]] Result<Maps> read_maps(const std::filesystem::path& directory,
                                     std::vector<std::string>& warnings);

}  // namespace psrig::formats
