#pragma once
// What the export tests share: a small maps directory of known content and
// size, and the Node.js validators of tools/node (install-deps puts them
// there; tests skip, saying so, where they are missing).

#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace psrig::test {

struct MapsSpec {
  int width = 200;
  int height = 120;
  std::optional<double> pixel_size_mm = 0.05;  // 10 x 6 mm
  bool report = true;
  bool height_map = true;
  std::string sample_id = "S-42";
};

// The maps written, and what they hold.
struct KnownMaps {
  std::filesystem::path directory;
  cv::Mat albedo;  // CV_8UC3, BGR
  cv::Mat normal;  // CV_16UC3, BGR
  cv::Mat height;  // CV_32F, mm
  double low = 0;
  double high = 0;
};

// A ribbed-knit-like surface: height, its normal map, a coloured albedo.
KnownMaps write_known_maps(const std::filesystem::path& directory, const MapsSpec& spec = {});

// node and a validator script of tools/node, or nothing (with the reason).
struct Validator {
  std::string command;  // "node /…/tools/node/SCRIPT"
};
std::optional<Validator> find_validator(const std::string& script, std::string& why_not);

// Runs `command` and parses what it prints as JSON.
nlohmann::json run_json(const std::string& command);

// The U3M 1.1 standard's folder (../shared/standards/u3m-1.1), or nothing.
std::optional<std::filesystem::path> u3m_standard();

}  // namespace psrig::test
