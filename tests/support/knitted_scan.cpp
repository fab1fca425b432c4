#include "knitted_scan.h"

#include <algorithm>

#include "psrig/capture/scan_writer.h"
#include "synthetic_scene.h"

namespace psrig::test {
namespace {

constexpr double kSlantDeg = 45;  // the default rig's LEDs
constexpr double kNoise = 0.002;  // of full scale, as the simulated sensor's

}  // namespace

Status write_knitted_scan(const KnittedMaps& maps, const std::string& structure,
                          const std::filesystem::path& directory) {
  Surface surface;
  surface.albedo = maps.albedo;
  surface.normal.create(maps.height.size(), CV_32FC3);
  const auto px = static_cast<float>(maps.pixel_size_mm);
  const auto at = [&](int r, int c) {
    return maps.height.at<float>(std::clamp(r, 0, maps.height.rows - 1),
                                 std::clamp(c, 0, maps.height.cols - 1));
  };
  for (int r = 0; r < maps.height.rows; ++r)
    for (int c = 0; c < maps.height.cols; ++c) {
      const float p = (at(r, c + 1) - at(r, c - 1)) / (2 * px);  // dz/dx
      const float q = (at(r - 1, c) - at(r + 1, c)) / (2 * px);  // dz/dy, y up
      const cv::Vec3f n(-p, -q, 1);
      surface.normal.at<cv::Vec3f>(r, c) = n / cv::norm(n);
    }
  processing::Scan scan = render_scan(surface, ring_lights(3, kSlantDeg), CV_16U, kNoise, 5);
  scan.description.pixel_size_mm = maps.pixel_size_mm;
  scan.description.sample_id = "knitted-" + structure;
  scan.description.document["fabric"] = {{"construction", "knit"}, {"structure", structure}};
  return capture::write_scan(scan, directory);
}

}  // namespace psrig::test
