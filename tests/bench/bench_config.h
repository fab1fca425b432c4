#pragma once
// The benchmarks' rig: config/sim.toml at 160x120 (or as `edits` say),
// scans under `temp`/scans, written beside them as rig.toml (or `name`).

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "test_support.h"

namespace psrig::test {

inline std::filesystem::path bench_config(
    const TempDir& temp, const std::vector<std::pair<std::string, std::string>>& edits = {},
    const std::string& name = "rig.toml") {
  std::ifstream in(std::filesystem::path(PSRIG_SOURCE_DIR) / "config/sim.toml");
  std::stringstream read;
  read << in.rdbuf();
  std::string text = read.str();
  const auto replace = [&](const std::string& from, const std::string& to) {
    if (const auto at = text.find(from); at != std::string::npos) text.replace(at, from.size(), to);
  };
  replace("width = 640", "width = 160");
  replace("height = 480", "height = 120");
  replace("root = \"../out/scans\"", "root = \"scans\"");
  for (const auto& [from, to] : edits)
    replace(from, to);
  const std::filesystem::path file = temp / name;
  std::ofstream(file) << text;
  return file;
}

}  // namespace psrig::test
