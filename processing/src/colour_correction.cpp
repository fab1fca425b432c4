#include "psrig/processing/colour_correction.h"

#include <cmath>

namespace psrig::processing {

Result<std::optional<ColourCorrection>> read_colour_correction(const nlohmann::json& scan_document,
                                                               const std::filesystem::path& file) {
  if (!scan_document.contains("colour_correction") || scan_document["colour_correction"].is_null())
    return std::optional<ColourCorrection>();
  const auto& section = scan_document["colour_correction"];
  const auto refuse = [&](const std::string& key, const std::string& why) {
    return std::unexpected(bad_input(file, "colour_correction." + key, why));
  };
  if (!section.is_object() || !section.contains("matrix"))
    return refuse("matrix", "expected {\"matrix\": [[r0], [r1], [r2]], \"space\": \"sRGB D65\"}");
  if (section.contains("space") && section["space"] != kAlbedoColourSpace)
    return refuse("space", "must be \"sRGB D65\" (the only colour space psrig corrects to)");
  const auto& m = section["matrix"];
  ColourCorrection c;
  if (!m.is_array() || m.size() != 3)
    return refuse("matrix", "expected 3 rows of 3 numbers (camera RGB to linear sRGB)");
  for (int r = 0; r < 3; ++r) {
    const auto& row = m[static_cast<std::size_t>(r)];
    if (!row.is_array() || row.size() != 3)
      return refuse("matrix", "expected 3 rows of 3 numbers (camera RGB to linear sRGB)");
    for (int k = 0; k < 3; ++k) {
      const auto& v = row[static_cast<std::size_t>(k)];
      if (!v.is_number() || !std::isfinite(v.get<double>()))
        return refuse("matrix", "holds a value that is not a finite number");
      c.rgb_matrix(r, k) = v.get<double>();
    }
  }
  if (std::abs(cv::determinant(c.rgb_matrix)) < 1e-9)
    return refuse("matrix", "is singular: run psrig calibrate colour again");
  if (section.contains("calibration") && section["calibration"].is_string())
    c.calibration = section["calibration"].get<std::string>();
  return std::optional<ColourCorrection>(c);
}

void apply_colour_matrix(const cv::Matx33d& rgb_matrix, cv::Mat& linear_bgr) {
  if (linear_bgr.channels() != 3) return;
  // The same matrix on BGR: rows and columns reversed.
  cv::Matx33f bgr;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      bgr(2 - r, 2 - c) = static_cast<float>(rgb_matrix(r, c));
  cv::Mat corrected;
  cv::transform(linear_bgr, corrected, bgr);
  linear_bgr = corrected;
}

}  // namespace psrig::processing
