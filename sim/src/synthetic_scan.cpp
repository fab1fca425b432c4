#include "psrig/sim/synthetic_scan.h"

#include <cmath>
#include <string>

#include "psrig/formats/light_matrix.h"
#include "psrig/formats/scan_layout.h"
#include "psrig/sim/fabric_truth.h"
#include "psrig/sim/lambertian_render.h"

namespace psrig::sim {

Result<formats::Scan> make_synthetic_scan(const SyntheticScanParams& params) {
  auto made = make_swatch(params.swatch);
  if (!made) return std::unexpected(std::move(made.error()));
  const Swatch& swatch = *made;
  const double full = params.depth == CV_8U ? 255.0 : 65535.0;
  cv::RNG random(params.swatch.seed * 0x9E3779B97F4A7C15ull + 1);

  formats::Scan scan;
  auto& d = scan.description;
  const std::string& pattern = params.swatch.pattern.name;
  d.sample_id = "synth-" + pattern + "-" + std::to_string(params.swatch.seed);
  d.sample_description = "synthetic " + pattern + " swatch (psrig synth)";
  d.pixel_size_mm = swatch.pixel_size_mm;
  d.white_level = full;
  scan.white_level = full;
  d.document = {{"capture",
                 {{"camera", "synth"},
                  {"slant_deg", params.slant_deg},
                  {"noise", params.noise},
                  {"seed", params.swatch.seed},
                  {"cast_shadows", params.cast_shadows}}}};
  // The gauge as made, for checking `psrig measure` (ground_truth.fabric).
  if (params.fabric_metadata) d.document["fabric"] = fabric_metadata(params.swatch.pattern);
  d.document["ground_truth"]["fabric"] =
      fabric_ground_truth(params.swatch.pattern, params.swatch.rotation_deg);

  for (int k = 0; k < 3; ++k) {
    const cv::Vec3d direction = formats::light_direction(120.0 * k, params.slant_deg);
    d.lights.push_back({formats::scan_files::led_frame(k, params.depth),
                        direction,
                        {1, 1, 1},
                        false,
                        std::nullopt});
    cv::Mat radiance = render_lambertian(swatch, {direction, {1, 1, 1}}, params.cast_shadows);
    radiance *= params.exposure;
    if (params.noise > 0) {
      cv::Mat noise(radiance.size(), radiance.type());
      random.fill(noise, cv::RNG::NORMAL, 0.0, params.noise);
      radiance += noise;
    }
    cv::Mat frame;
    radiance.convertTo(frame, CV_MAKETYPE(params.depth, 3),
                       full);  // rounds and clips to the sensor range
    scan.frames.push_back(frame);
  }
  scan.ground_truth_normal = swatch.normal;
  scan.ground_truth_height = swatch.height_mm;
  return scan;
}

}  // namespace psrig::sim
