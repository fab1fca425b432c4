#include "export_fixture.h"

#include <cmath>
#include <cstdio>
#include <fstream>

#include <opencv2/imgcodecs.hpp>

#include "psrig/formats/image_io.h"
#include "psrig/formats/map_encoding.h"

namespace psrig::test {

namespace fs = std::filesystem;

KnownMaps write_known_maps(const fs::path& directory, const MapsSpec& spec) {
  fs::create_directories(directory);
  KnownMaps maps;
  maps.directory = directory;
  const double s = spec.pixel_size_mm.value_or(1.0);
  cv::Mat height(spec.height, spec.width, CV_32F);
  cv::Mat p(height.size(), CV_32F);
  cv::Mat q(height.size(), CV_32F);
  maps.albedo.create(height.size(), CV_8UC3);
  // Ribs: z = a sin(2 pi x / L) + b cos(2 pi y / M), x right, y up (mm).
  const double a = 0.08, b = 0.03, L = 40 * s, M = 25 * s;
  for (int r = 0; r < spec.height; ++r)
    for (int c = 0; c < spec.width; ++c) {
      const double x = c * s, y = -r * s;
      height.at<float>(r, c) =
          static_cast<float>(a * std::sin(2 * CV_PI * x / L) + b * std::cos(2 * CV_PI * y / M));
      p.at<float>(r, c) = static_cast<float>(a * 2 * CV_PI / L * std::cos(2 * CV_PI * x / L));
      q.at<float>(r, c) = static_cast<float>(-b * 2 * CV_PI / M * std::sin(2 * CV_PI * y / M));
      const double shade = 0.5 + 0.5 * std::sin(2 * CV_PI * x / L);
      maps.albedo.at<cv::Vec3b>(r, c) = {static_cast<std::uint8_t>(40 + 60 * shade),
                                         static_cast<std::uint8_t>(90 + 50 * shade),
                                         static_cast<std::uint8_t>(150 + 90 * shade)};
    }
  // The gradients of the pixel grid: p per pixel in mm over mm is unitless.
  maps.height = height;
  maps.normal = formats::encode_normal16(p, q);
  cv::minMaxLoc(height, &maps.low, &maps.high);
  (void)formats::write_image(directory / "albedo.png", maps.albedo);
  (void)formats::write_image(directory / "normal.png", maps.normal);
  if (spec.height_map) {
    (void)formats::write_image(directory / "height.exr", height);
    (void)formats::write_image(directory / "height.png",
                               formats::encode_height16(height, maps.low, maps.high));
  }
  if (spec.report) {
    nlohmann::json report = {
        {"format", "psrig-report/1"},
        {"inputs",
         {{"pixel_size_mm", spec.pixel_size_mm ? nlohmann::json(*spec.pixel_size_mm) : nullptr},
          {"sample", {{"id", spec.sample_id}, {"description", "a ribbed test knit"}}},
          {"capture", {{"started", "2026-11-25T03:00:00Z"}}}}},
        {"height",
         {{"png_range", {maps.low, maps.high}}, {"units", spec.pixel_size_mm ? "mm" : "px"}}}};
    std::ofstream(directory / "report.json") << report.dump(2);
  }
  return maps;
}

std::optional<Validator> find_validator(const std::string& script, std::string& why_not) {
  const fs::path tools = fs::path(PSRIG_SOURCE_DIR) / "tools" / "node";
  if (std::system("node --version > /dev/null 2>&1") != 0) {
    why_not = "node is not installed (scripts/install-deps installs it)";
    return std::nullopt;
  }
  if (!fs::exists(tools / "node_modules")) {
    why_not =
        (tools / "node_modules").string() + " is missing (scripts/install-deps runs npm ci there)";
    return std::nullopt;
  }
  return Validator{"node " + (tools / script).string()};
}

nlohmann::json run_json(const std::string& command) {
  std::FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return nullptr;
  std::string out;
  char buffer[4096];
  while (std::size_t n = std::fread(buffer, 1, sizeof buffer, pipe))
    out.append(buffer, n);
  ::pclose(pipe);
  auto doc = nlohmann::json::parse(out, nullptr, false);
  if (doc.is_discarded()) return {{"unparsed_output", out}};
  return doc;
}

std::optional<fs::path> u3m_standard() {
  const fs::path folder = fs::path(PSRIG_SOURCE_DIR) / ".." / "shared" / "standards" / "u3m-1.1";
  if (fs::exists(folder / "u3m_schema.json")) return folder.lexically_normal();
  return std::nullopt;
}

}  // namespace psrig::test
