#include "psrig/sim/swatch_model.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "crease_fill.h"
#include "psrig/cloth/yarn_raster.h"
#include "sim_hash.h"
#include "swatch_yarns.h"

namespace psrig::sim {
namespace {

// Steepest flank of a yarn, tan(55 deg): past it, fibres fill the crease.
constexpr double kFibreSkirtSlope = 1.43;

// Normals from the height by central differences (one-sided at the borders),
// in camera axes: y up, so q takes the row above minus the row below.
cv::Mat normals_from_height(const cv::Mat& height, double px) {
  cv::Mat normal(height.size(), CV_32FC3);
  const int rows = height.rows;
  const int cols = height.cols;
  cv::parallel_for_(cv::Range(0, rows), [&](const cv::Range& range) {
    for (int r = range.start; r < range.end; ++r) {
      const int up = std::max(r - 1, 0);
      const int down = std::min(r + 1, rows - 1);
      const float qscale = up == down ? 0.0f : static_cast<float>(1.0 / ((down - up) * px));
      const auto* zu = height.ptr<float>(up);
      const auto* zd = height.ptr<float>(down);
      const auto* z = height.ptr<float>(r);
      auto* n = normal.ptr<cv::Vec3f>(r);
      for (int c = 0; c < cols; ++c) {
        const int left = std::max(c - 1, 0);
        const int right = std::min(c + 1, cols - 1);
        const float pscale = left == right ? 0.0f : static_cast<float>(1.0 / ((right - left) * px));
        const float p = (z[right] - z[left]) * pscale;
        const float q = (zu[c] - zd[c]) * qscale;
        const float inv = 1.0f / std::sqrt(p * p + q * q + 1.0f);
        n[c] = {-p * inv, -q * inv, inv};
      }
    }
  });
  return normal;
}

}  // namespace

Result<Swatch> make_swatch(const SwatchParams& params) {
  Swatch swatch;
  swatch.pixel_size_mm = params.pixel_size_mm;
  if (params.size.width <= 0 || params.size.height <= 0 || !(params.pixel_size_mm > 0)) {
    return swatch;
  }
  const double px = params.pixel_size_mm;
  const cv::Size size = params.size;
  auto yarns = detail::swatch_yarns(params.pattern, size, px, params.rotation_deg, params.seed);
  if (!yarns) return std::unexpected(yarns.error());
  swatch.cloth_to_image = yarns->cloth_to_image;

  cloth::YarnRaster raster =
      cloth::rasterize_yarns(yarns->yarns, size, px, yarns->floor_mm, kFibreSkirtSlope);
  detail::fill_creases(raster, px, kFibreSkirtSlope);

  // Ply twist, fibre texture and colour on top of the yarn tubes.
  cv::Mat height(size, CV_32F);
  swatch.albedo.create(size, CV_32FC3);
  const auto relief = static_cast<float>(yarns->fibre_relief_mm);
  cv::parallel_for_(cv::Range(0, size.height), [&](const cv::Range& range) {
    for (int r = range.start; r < range.end; ++r) {
      const auto* top = raster.top.ptr<float>(r);
      const auto* id = raster.yarn.ptr<int>(r);
      const auto* along = raster.along.ptr<float>(r);
      const auto* across = raster.across.ptr<float>(r);
      auto* h = height.ptr<float>(r);
      auto* albedo = swatch.albedo.ptr<cv::Vec3f>(r);
      for (int c = 0; c < size.width; ++c) {
        if (id[c] < 0) {
          h[c] = top[c];
          albedo[c] = yarns->gap_bgr;
          continue;
        }
        const detail::YarnLook& look = yarns->looks[static_cast<std::size_t>(id[c])];
        const float a = across[c];
        const float s = along[c];
        // A ply boundary is a helix: seen from above, the angle round the
        // yarn is asin(across), and it advances one turn per twist pitch.
        const float turns =
            s / look.twist_pitch_mm + std::asin(a) * static_cast<float>(0.5 / std::numbers::pi);
        const float psi = static_cast<float>(look.plies) * turns;
        const float nearest = std::floor(psi + 0.5f);
        const float cosine = std::cos(static_cast<float>(std::numbers::pi) * psi);
        const float groove = cosine * cosine * cosine * cosine;  // narrow, between the plies
        const float crown = std::sqrt(std::max(0.0f, 1.0f - a * a));
        const float across_mm = a * look.half_width_mm;
        // Fibres run along the yarn: texture stretched along it, fine across it,
        // a little proud and a little lighter where they bunch.
        const float fibres = detail::value_noise(s / 0.4f, across_mm / 0.05f, look.key);
        h[c] = top[c] - look.groove_mm * groove * crown + relief * fibres;
        const bool odd_ply = (static_cast<std::int64_t>(nearest) & 1) != 0;
        const float variation = (odd_ply ? 1.025f : 0.975f) * (1.0f + 0.035f * fibres);
        albedo[c] = look.colour_at(s) * variation;
      }
    }
  });
  raster = {};

  // Below a quarter pixel the blur would do nothing visible.
  const double sigma_px = yarns->smoothing_mm / px;
  if (sigma_px > 0.25) {
    cv::GaussianBlur(height, height, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REFLECT);
  }
  double lowest = 0;
  cv::minMaxLoc(height, &lowest);
  height -= lowest;
  swatch.height_mm = height;
  swatch.normal = normals_from_height(height, px);
  cv::min(swatch.albedo, cv::Scalar::all(0.9), swatch.albedo);
  cv::max(swatch.albedo, cv::Scalar::all(0.03), swatch.albedo);
  return swatch;
}

}  // namespace psrig::sim
