#include "psrig/sim/colour_chart_target.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "psrig/calibration/colour.h"
#include "psrig/sim/card_target.h"
#include "target_sampling.h"

namespace psrig::sim {

namespace {

// The chart's layout in patch units: patches 1, gaps 0.1 (OpenCV mcc's
// model), a black frame of 0.4 around them.
constexpr double kGap = 0.1;
constexpr double kFrame = 0.4;
constexpr double kChartWidth = 6 + 5 * kGap + 2 * kFrame;
constexpr double kChartHeight = 4 + 3 * kGap + 2 * kFrame;

}  // namespace

Swatch colour_chart(cv::Size size, double pixel_size_mm) {
  const cv::Size fine(size.width * kSamplesPerPixel, size.height * kSamplesPerPixel);
  // Patch size in fine samples.
  const double unit = std::min(0.85 * fine.width / kChartWidth, 0.85 * fine.height / kChartHeight);
  const cv::Point2d centre((fine.width - 1) / 2.0, (fine.height - 1) / 2.0);
  const double turn = kChartTurnDeg * std::numbers::pi / 180;
  // Chart units (0,0 the frame's top left, x right, y down) to fine samples.
  const auto place = [&](double x, double y) {
    const double u = (x - kChartWidth / 2) * unit, v = (y - kChartHeight / 2) * unit;
    return cv::Point2d(centre.x + u * std::cos(turn) - v * std::sin(turn),
                       centre.y + u * std::sin(turn) + v * std::cos(turn));
  };
  // Sub-pixel vertices: fillConvexPoly with 8 fractional bits.
  constexpr int kShift = 8;
  const auto fill = [&](cv::Mat& image, double x0, double y0, double x1, double y1,
                        const cv::Scalar& colour) {
    std::vector<cv::Point> polygon;
    for (const auto& p : {place(x0, y0), place(x1, y0), place(x1, y1), place(x0, y1)})
      polygon.emplace_back(static_cast<int>(std::lround(p.x * (1 << kShift))),
                           static_cast<int>(std::lround(p.y * (1 << kShift))));
    cv::fillConvexPoly(image, polygon, colour, cv::LINE_8, kShift);
  };
  cv::Mat albedo(fine, CV_32FC3, cv::Scalar::all(kChartCardAlbedo));
  fill(albedo, 0, 0, kChartWidth, kChartHeight, cv::Scalar::all(kChartFrameAlbedo));
  const auto& patches = calibration::colorchecker_classic();
  for (int p = 0; p < calibration::kChartPatches; ++p) {
    const double x = kFrame + (1 + kGap) * (p % calibration::kChartColumns);
    const double y = kFrame + (1 + kGap) * (p / calibration::kChartColumns);
    // Reflectance is the sRGB triple itself; the cyan patch lies just
    // outside sRGB (a red of -0.01), kept so the chart is the reference.
    const cv::Vec3d rgb =
        calibration::lab_d50_to_linear_srgb(patches[static_cast<std::size_t>(p)].lab_d50);
    fill(albedo, x, y, x + 1, y + 1, cv::Scalar(rgb[2], rgb[1], rgb[0]));
  }
  Swatch card = white_card(size, pixel_size_mm);
  cv::resize(albedo, card.albedo, size, 0, 0, cv::INTER_AREA);
  return card;
}

}  // namespace psrig::sim
