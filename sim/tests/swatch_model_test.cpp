// The simulated world's textile (make_swatch) and its image formation
// (render_lambertian, cast_shadow_mask).

#include "psrig/sim/swatch_model.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numbers>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "psrig/cloth/knit_fabric.h"
#include "psrig/formats/light_matrix.h"
#include "psrig/sim/lambertian_render.h"
#include "shipped_swatch.h"

namespace psrig::sim {
namespace {

// One of each structure the simulator had before patterns were files (the
// older names, aliases of shipped ones); swatch_pattern_test.cpp and the
// pipeline tests take every shipped pattern.
constexpr std::array<std::string_view, 5> kPatterns{"jersey", "rib", "garter", "plain", "twill"};

// Stated in swatch_model.cpp: yarn flanks stop at 55 deg and fibres fill the
// creases at that slope; ply grooves and fibre texture add a few degrees.
constexpr double kMaxSlopeDeg = 65.0;

double radians(double degrees) {
  return degrees * std::numbers::pi / 180.0;
}

using formats::light_direction;

Swatch swatch_of(std::string_view pattern, cv::Size size = {640, 480}, double px = 0.025,
                 std::uint64_t seed = 1) {
  return test::made(make_swatch(test::swatch_params(pattern, size, px, seed)));
}

bool identical(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  for (int r = 0; r < a.rows; ++r) {
    if (std::memcmp(a.ptr(r), b.ptr(r), a.cols * a.elemSize()) != 0) return false;
  }
  return true;
}

// Dominant period, in pixels, of the height along x: the peak of the power
// spectrum of each row averaged over the rows, refined by a parabola.
double dominant_period_along_x(const cv::Mat& height) {
  cv::Mat rows = height.clone();
  for (int r = 0; r < rows.rows; ++r) {
    cv::Mat row = rows.row(r);
    row -= cv::mean(row)[0];
  }
  cv::Mat spectrum;
  cv::dft(rows, spectrum, cv::DFT_ROWS | cv::DFT_COMPLEX_OUTPUT);
  const int n = rows.cols;
  std::vector<double> power(static_cast<std::size_t>(n / 2 + 1), 0.0);
  for (int r = 0; r < spectrum.rows; ++r) {
    const auto* f = spectrum.ptr<cv::Vec2f>(r);
    for (int k = 0; k <= n / 2; ++k)
      power[static_cast<std::size_t>(k)] += f[k].dot(f[k]);
  }
  std::size_t best = 1;
  for (std::size_t k = 2; k + 1 < power.size(); ++k) {
    if (power[k] > power[best]) best = k;
  }
  double shift = 0;
  if (best + 1 < power.size()) {
    const double a = power[best - 1];
    const double b = power[best];
    const double c = power[best + 1];
    if (a - 2 * b + c < 0) shift = 0.5 * (a - c) / (a - 2 * b + c);
  }
  return n / (static_cast<double>(best) + shift);
}

double per_cm(double period_px, double px) {
  return 10.0 / (period_px * px);
}

// Circular autocorrelation of the height (mean removed), 1 at zero lag.
cv::Mat autocorrelation(const cv::Mat& height) {
  cv::Mat centred = height - cv::mean(height)[0];
  cv::Mat spectrum;
  cv::dft(centred, spectrum, cv::DFT_COMPLEX_OUTPUT);
  cv::Mat power;
  cv::mulSpectrums(spectrum, spectrum, power, 0, true);
  cv::Mat corr;
  cv::dft(power, corr, cv::DFT_INVERSE | cv::DFT_REAL_OUTPUT | cv::DFT_SCALE);
  return corr / corr.at<float>(0, 0);
}

struct Peak {
  cv::Vec2i lag;  // (x, y) in pixels, camera axes: y up
  double value;
};

double corr_at(const cv::Mat& corr, int x, int y) {
  // y up: a lag of +y is a row above.
  return corr.at<float>(((-y) % corr.rows + corr.rows) % corr.rows,
                        (x % corr.cols + corr.cols) % corr.cols);
}

// The highest autocorrelation at lags between from_px and to_px from zero;
// autocorrelation is symmetric, so only lags with x >= 0 are searched.
Peak highest_peak(const cv::Mat& corr, double from_px, double to_px) {
  Peak best{{0, 0}, -2.0};
  const int reach = static_cast<int>(std::ceil(to_px));
  for (int y = -reach; y <= reach; ++y) {
    for (int x = 0; x <= reach; ++x) {
      const double r = std::hypot(x, y);
      if (r < from_px || r > to_px) continue;
      const double v = corr_at(corr, x, y);
      if (v > best.value) best = {{x, y}, v};
    }
  }
  return best;
}

// The highest autocorrelation within `radius` pixels of a lag.
double peak_near(const cv::Mat& corr, cv::Vec2i lag, int radius) {
  double best = -2.0;
  for (int y = lag[1] - radius; y <= lag[1] + radius; ++y) {
    for (int x = lag[0] - radius; x <= lag[0] + radius; ++x)
      best = std::max(best, corr_at(corr, x, y));
  }
  return best;
}

double mean_square(const cv::Mat& m) {
  const cv::Scalar s = cv::mean(m.mul(m));
  return s[0];
}

// Surface gradients by central differences, as the normals are defined.
void gradients(const cv::Mat& height, double px, cv::Mat& p, cv::Mat& q) {
  p = cv::Mat::zeros(height.size(), CV_32F);
  q = cv::Mat::zeros(height.size(), CV_32F);
  for (int r = 1; r + 1 < height.rows; ++r) {
    for (int c = 1; c + 1 < height.cols; ++c) {
      p.at<float>(r, c) =
          static_cast<float>((height.at<float>(r, c + 1) - height.at<float>(r, c - 1)) / (2 * px));
      q.at<float>(r, c) =
          static_cast<float>((height.at<float>(r - 1, c) - height.at<float>(r + 1, c)) / (2 * px));
    }
  }
}

Swatch flat_swatch(cv::Size size, cv::Vec3f albedo, double px = 0.05) {
  Swatch s;
  s.height_mm = cv::Mat::zeros(size, CV_32F);
  s.normal = cv::Mat(size, CV_32FC3, cv::Scalar(0, 0, 1));
  s.albedo = cv::Mat(size, CV_32FC3, cv::Scalar(albedo[0], albedo[1], albedo[2]));
  s.pixel_size_mm = px;
  return s;
}

// ---------------------------------------------------------------- model

TEST(SwatchModelTest, SameSeedSameSwatchBitForBit) {
  for (std::string_view pattern : kPatterns) {
    const Swatch a = swatch_of(pattern, {320, 240}, 0.025, 42);
    const Swatch b = swatch_of(pattern, {320, 240}, 0.025, 42);
    EXPECT_TRUE(identical(a.height_mm, b.height_mm)) << pattern;
    EXPECT_TRUE(identical(a.normal, b.normal)) << pattern;
    EXPECT_TRUE(identical(a.albedo, b.albedo)) << pattern;
  }
}

TEST(SwatchModelTest, SameSwatchWhateverTheThreadCount) {
  const int threads = cv::getNumThreads();
  const Swatch many = swatch_of("rib", {400, 300}, 0.02, 7);
  cv::setNumThreads(1);
  const Swatch one = swatch_of("rib", {400, 300}, 0.02, 7);
  cv::setNumThreads(threads);
  EXPECT_TRUE(identical(many.height_mm, one.height_mm));
  EXPECT_TRUE(identical(many.albedo, one.albedo));
}

TEST(SwatchModelTest, DifferentSeedsDiffer) {
  for (std::string_view pattern : kPatterns) {
    const Swatch a = swatch_of(pattern, {320, 240}, 0.025, 1);
    const Swatch b = swatch_of(pattern, {320, 240}, 0.025, 2);
    EXPECT_GT(cv::norm(a.height_mm, b.height_mm, cv::NORM_INF), 0.01) << pattern;
    EXPECT_GT(cv::norm(a.albedo, b.albedo, cv::NORM_INF), 0.01) << pattern;
  }
}

TEST(SwatchModelTest, NormalsAreUnitAndMatchTheHeight) {
  for (std::string_view pattern : kPatterns) {
    const double px = 0.025;
    const Swatch s = swatch_of(pattern, {300, 200}, px, 3);
    ASSERT_EQ(s.normal.type(), CV_32FC3);
    ASSERT_EQ(s.normal.size(), s.height_mm.size());
    const cv::Mat& z = s.height_mm;
    const auto expected = [&](int r, int c) {
      // Central differences, one-sided at the borders; y is up, so q takes
      // the row above minus the row below.
      const int l = std::max(c - 1, 0);
      const int rt = std::min(c + 1, z.cols - 1);
      const int up = std::max(r - 1, 0);
      const int dn = std::min(r + 1, z.rows - 1);
      const double p = (double{z.at<float>(r, rt)} - z.at<float>(r, l)) / ((rt - l) * px);
      const double q = (double{z.at<float>(up, c)} - z.at<float>(dn, c)) / ((dn - up) * px);
      return cv::Vec3d(-p, -q, 1.0) / std::sqrt(p * p + q * q + 1.0);
    };
    for (int r = 0; r < z.rows; r += 7) {
      for (int c = 0; c < z.cols; c += 5) {
        const cv::Vec3d n = s.normal.at<cv::Vec3f>(r, c);
        ASSERT_NEAR(cv::norm(n), 1.0, 1e-5) << pattern << " at " << r << "," << c;
        const cv::Vec3d e = expected(r, c);
        ASSERT_LT(cv::norm(n - e), 1e-5) << pattern << " at " << r << "," << c;
      }
    }
    // The borders too, where the differences are one-sided.
    for (int r : {0, z.rows - 1}) {
      for (int c : {0, z.cols / 2, z.cols - 1}) {
        EXPECT_LT(cv::norm(cv::Vec3d(s.normal.at<cv::Vec3f>(r, c)) - expected(r, c)), 1e-5);
      }
    }
  }
}

TEST(SwatchModelTest, JerseyWalesScaleWithPixelSize) {
  for (double px : {0.025, 0.04}) {
    const Swatch s = swatch_of("jersey", {1024, 256}, px, 5);
    const double wales = per_cm(dominant_period_along_x(s.height_mm), px);
    EXPECT_GE(wales, 6.0) << "pixel size " << px;
    EXPECT_LE(wales, 8.0) << "pixel size " << px;
  }
}

TEST(SwatchModelTest, JerseyCoursesAlongY) {
  const double px = 0.025;
  const Swatch s = swatch_of("jersey", {256, 1024}, px, 5);
  const double courses = per_cm(dominant_period_along_x(s.height_mm.t()), px);
  EXPECT_GE(courses, 8.0);
  EXPECT_LE(courses, 10.0);
}

TEST(SwatchModelTest, PlainWeaveThreadCounts) {
  for (double px : {0.01, 0.02}) {
    const Swatch s = swatch_of("plain", {1024, 1024}, px, 9);
    const double ends = per_cm(dominant_period_along_x(s.height_mm), px);
    const double picks = per_cm(dominant_period_along_x(s.height_mm.t()), px);
    EXPECT_GE(ends, 20.0) << "pixel size " << px;
    EXPECT_LE(ends, 30.0) << "pixel size " << px;
    EXPECT_GE(picks, 20.0) << "pixel size " << px;
    EXPECT_LE(picks, 30.0) << "pixel size " << px;
  }
}

TEST(SwatchModelTest, GarterRidgesRunAcrossRibWalesRunDown) {
  const double px = 0.025;
  cv::Mat p;
  cv::Mat q;
  gradients(swatch_of("garter", {640, 480}, px).height_mm, px, p, q);
  EXPECT_GT(mean_square(q), 1.5 * mean_square(p)) << "garter: ridges should make y dominate";
  gradients(swatch_of("rib", {640, 480}, px).height_mm, px, p, q);
  EXPECT_GT(mean_square(p), 1.5 * mean_square(q)) << "rib: wales should make x dominate";
}

TEST(SwatchModelTest, TwillAutocorrelationPeaksAlongADiagonal) {
  // A 2/2 twill repeats exactly when shifted one end across and one pick up
  // (its diagonal rib), and not along the axes until four threads; shifted
  // along the other diagonal, its over/under is inverted.
  const double px = 0.02;
  const cv::Mat twill = autocorrelation(swatch_of("twill", {512, 512}, px).height_mm);
  const Peak peak = highest_peak(twill, 0.25 / px, 1.2 / px);
  const double angle = std::atan2(peak.lag[1], peak.lag[0]) * 180.0 / std::numbers::pi;
  EXPECT_GT(angle, 20.0) << "peak at lag (" << peak.lag[0] << ", " << peak.lag[1] << ")";
  EXPECT_LT(angle, 70.0) << "a right-hand twill's ribs rise to the right";
  EXPECT_GT(peak.value, 0.5);
  const cv::Vec2i mirror{peak.lag[0], -peak.lag[1]};
  EXPECT_LT(peak_near(twill, mirror, 2), peak.value - 0.4);

  // Plain weave is symmetric: both diagonals repeat alike.
  const cv::Mat plain = autocorrelation(swatch_of("plain", {512, 512}, px).height_mm);
  const double sx = 10.0 / 24 / px;  // the plain weave's thread spacings, roughly
  const double sy = 10.0 / 22 / px;
  const cv::Vec2i diagonal{static_cast<int>(std::lround(sx)), static_cast<int>(std::lround(sy))};
  EXPECT_NEAR(peak_near(plain, diagonal, 3), peak_near(plain, {diagonal[0], -diagonal[1]}, 3), 0.1);
}

TEST(SwatchModelTest, PhysicallyPlausibleReliefSlopeAndAlbedo) {
  for (std::string_view pattern : kPatterns) {
    for (double px : {0.01, 0.025, 0.06}) {
      const Swatch s = swatch_of(pattern, {400, 300}, px, 11);
      SCOPED_TRACE(std::string(pattern) + " at " + std::to_string(px) + " mm/px");
      ASSERT_EQ(s.height_mm.type(), CV_32F);
      ASSERT_EQ(s.albedo.type(), CV_32FC3);
      EXPECT_EQ(s.pixel_size_mm, px);
      EXPECT_TRUE(cv::checkRange(s.height_mm));
      double lo = 0;
      double hi = 0;
      cv::minMaxLoc(s.height_mm, &lo, &hi);
      EXPECT_EQ(lo, 0.0);
      EXPECT_GE(hi, 0.1);
      EXPECT_LE(hi, 1.0);
      std::vector<cv::Mat> n;
      cv::split(s.normal, n);
      double nz_min = 0;
      cv::minMaxLoc(n[2], &nz_min);
      EXPECT_LT(std::acos(nz_min) * 180.0 / std::numbers::pi, kMaxSlopeDeg);
      double a_lo = 0;
      double a_hi = 0;
      cv::minMaxLoc(s.albedo.reshape(1), &a_lo, &a_hi);
      EXPECT_GE(a_lo, 0.03);
      EXPECT_LE(a_hi, 0.9);
    }
  }
}

TEST(SwatchModelTest, TwillHasIndigoWarpAndWhiteWeft) {
  const Swatch s = swatch_of("twill", {400, 300}, 0.02);
  int blue = 0;
  int white = 0;
  for (int r = 0; r < s.albedo.rows; ++r) {
    for (int c = 0; c < s.albedo.cols; ++c) {
      const cv::Vec3f a = s.albedo.at<cv::Vec3f>(r, c);  // BGR
      if (a[0] > 2.5f * a[2]) ++blue;
      if (a[0] > 0.5f && a[1] > 0.5f && a[2] > 0.5f) ++white;
    }
  }
  const double total = static_cast<double>(s.albedo.total());
  EXPECT_GT(blue / total, 0.3);
  EXPECT_GT(white / total, 0.15);
}

TEST(SwatchModelTest, AnySizeWorks) {
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(1, 9), cv::Size(9, 1), cv::Size(37, 23)}) {
    const Swatch s = swatch_of("jersey", size);
    ASSERT_EQ(s.height_mm.size(), size);
    ASSERT_EQ(s.normal.size(), size);
    ASSERT_EQ(s.albedo.size(), size);
    EXPECT_TRUE(cv::checkRange(s.normal));
    for (int r = 0; r < size.height; ++r) {
      for (int c = 0; c < size.width; ++c) {
        EXPECT_NEAR(cv::norm(s.normal.at<cv::Vec3f>(r, c)), 1.0, 1e-5);
      }
    }
  }
  const Swatch empty = swatch_of("plain", {0, 10});
  EXPECT_TRUE(empty.height_mm.empty());
  EXPECT_TRUE(empty.normal.empty());
}

TEST(SwatchModelTest, NoPatternIsBadInput) {
  SwatchParams params;
  params.size = {32, 32};
  const auto swatch = make_swatch(params);
  ASSERT_FALSE(swatch);
  EXPECT_EQ(swatch.error().kind, ErrorKind::bad_input);
}

// ---------------------------------------------------------------- the chart on the swatch

// Every place of the cloth's plane that repeats `at` (mm from the lower left
// of stitch (0, 0)) by whole repeats of `repeat` mm, in image pixels, kept
// `margin` pixels inside the image.
std::vector<cv::Point2d> repeated_in_image(const Swatch& s, cv::Point2d at, cv::Size2d repeat,
                                           int margin) {
  cv::Matx23d to_cloth;
  cv::invertAffineTransform(s.cloth_to_image, to_cloth);
  double lo_x = 1e9, hi_x = -1e9, lo_y = 1e9, hi_y = -1e9;
  for (const cv::Point2d corner :
       {cv::Point2d(0, 0), cv::Point2d(s.albedo.cols, 0), cv::Point2d(0, s.albedo.rows),
        cv::Point2d(s.albedo.cols, s.albedo.rows)}) {
    const cv::Vec2d q = to_cloth * cv::Vec3d(corner.x, corner.y, 1);
    lo_x = std::min(lo_x, q[0]), hi_x = std::max(hi_x, q[0]);
    lo_y = std::min(lo_y, q[1]), hi_y = std::max(hi_y, q[1]);
  }
  std::vector<cv::Point2d> points;
  for (auto i = static_cast<int>(std::floor(lo_x / repeat.width)) - 1; i * repeat.width <= hi_x;
       ++i)
    for (auto j = static_cast<int>(std::floor(lo_y / repeat.height)) - 1; j * repeat.height <= hi_y;
         ++j) {
      const cv::Vec2d p =
          s.cloth_to_image * cv::Vec3d(at.x + i * repeat.width, at.y + j * repeat.height, 1);
      if (p[0] >= margin && p[1] >= margin && p[0] < s.albedo.cols - margin &&
          p[1] < s.albedo.rows - margin)
        points.emplace_back(p[0], p[1]);
    }
  return points;
}

// The chart's repeat as the cloth lays it out (cloth::KnitFabric).
cloth::KnitRepeatLayout layout_of(const SwatchPattern& pattern) {
  const auto& chart = std::get<cloth::StitchChart>(pattern.cloth);
  return test::made(cloth::KnitFabric::build(chart, chart.columns, chart.rows, {})).repeat();
}

// A 2x2 rib's knit wales stand out of its purl wales: along the chart's
// knit columns the height is up, along its purl columns down, and shifted
// by a column or two the chart no longer fits. Laid square and turned.
TEST(SwatchModelTest, ARibsWalesStandWhereItsChartSays) {
  for (const double turn : {0.0, 10.0}) {
    SwatchParams params = test::swatch_params("rib-2x2", {480, 360}, 0.02, 4);
    params.rotation_deg = turn;
    const Swatch s = test::made(make_swatch(params));
    const auto& chart = std::get<cloth::StitchChart>(params.pattern.cloth);
    const cloth::KnitRepeatLayout layout = layout_of(params.pattern);
    // Mean height along each chart column's centre line.
    std::vector<double> column_height;
    for (int column = 0; column < chart.columns; ++column) {
      double sum = 0;
      int count = 0;
      for (int step = 0; step < 8; ++step) {
        const cv::Point2d at(layout.column_x_mm[static_cast<std::size_t>(column)],
                             layout.height_mm * step / 8.0);
        for (const cv::Point2d p :
             repeated_in_image(s, at, {layout.width_mm, layout.height_mm}, 2)) {
          sum += s.height_mm.at<float>(cvRound(p.y), cvRound(p.x));
          ++count;
        }
      }
      ASSERT_GT(count, 100);
      column_height.push_back(sum / count);
    }
    // Knit columns minus purl ones, for the chart as placed and shifted.
    const auto contrast = [&](int shift) {
      double knit = 0, purl = 0;
      for (int column = 0; column < chart.columns; ++column)
        (chart.at(column + shift, 0) == cloth::Stitch::knit ? knit : purl) +=
            column_height[static_cast<std::size_t>(column)];
      return (knit - purl) / (chart.columns / 2);
    };
    SCOPED_TRACE("turned " + std::to_string(turn));
    EXPECT_GT(contrast(0), 0.05) << "mm";
    for (const int shift : {1, 2, 3})
      EXPECT_LT(contrast(shift), 0.5 * contrast(0)) << shift;
  }
}

// Stripes: each course shows its chart row's colour (cream, cream, navy,
// navy) on the legs of its V's; two courses off, the colours swap.
TEST(SwatchModelTest, StripesShowTheChartsColoursInTheirCourses) {
  SwatchParams params = test::swatch_params("stripes", {480, 360}, 0.02, 6);
  params.rotation_deg = -7;
  const Swatch s = test::made(make_swatch(params));
  const auto& chart = std::get<cloth::StitchChart>(params.pattern.cloth);
  const cloth::KnitRepeatLayout layout = layout_of(params.pattern);
  const auto bright = [&](cv::Point2d p) {
    const cv::Vec3f bgr = s.albedo.at<cv::Vec3f>(cvRound(p.y), cvRound(p.x));
    return bgr[2] > 0.3f;  // cream's red is 0.8, navy's 0.01
  };
  const auto matching = [&](int shift) {
    int agree = 0, total = 0;
    for (int row = 0; row < chart.rows; ++row) {
      const auto r = static_cast<std::size_t>(row);
      const bool cream = chart.colour_at(0, row + shift) == 0;
      for (const double leg : {-0.22, 0.22}) {
        const cv::Point2d at(layout.column_x_mm[0] + leg * layout.column_width_mm[0],
                             layout.row_y_mm[r] + 0.5 * layout.row_height_mm[r]);
        for (const cv::Point2d p :
             repeated_in_image(s, at, {layout.width_mm, layout.height_mm}, 2)) {
          agree += bright(p) == cream ? 1 : 0;
          ++total;
        }
      }
    }
    return static_cast<double>(agree) / total;
  };
  EXPECT_GT(matching(0), 0.95);
  EXPECT_LT(matching(2), 0.05);
}

// ---------------------------------------------------------------- rendering

TEST(LambertRenderTest, FlatSwatchGivesAlbedoTimesIntensityTimesCosSlant) {
  const cv::Vec3f albedo{0.2f, 0.4f, 0.6f};
  const Swatch s = flat_swatch({16, 12}, albedo);
  for (double slant : {0.0, 30.0, 60.0}) {
    DistantLight light;
    light.direction = light_direction(40.0, slant) * 3.0;  // need not be unit
    light.intensity_bgr = {1.0f, 0.5f, 2.0f};
    const cv::Mat img = render_lambertian(s, light);
    ASSERT_EQ(img.type(), CV_32FC3);
    ASSERT_EQ(img.size(), s.normal.size());
    const double cosine = std::cos(radians(slant));
    for (int r = 0; r < img.rows; ++r) {
      for (int c = 0; c < img.cols; ++c) {
        const cv::Vec3f v = img.at<cv::Vec3f>(r, c);
        for (int k = 0; k < 3; ++k) {
          ASSERT_NEAR(v[k], albedo[k] * light.intensity_bgr[k] * cosine, 1e-6);
        }
      }
    }
  }
}

TEST(LambertRenderTest, TiltedFacetsFollowTheCosineAndTurnedAwayAreBlack) {
  Swatch s = flat_swatch({2, 1}, {0.5f, 0.5f, 0.5f});
  // A facet tilted 40 deg toward +x and one tilted 80 deg toward -x.
  s.normal.at<cv::Vec3f>(0, 0) = {static_cast<float>(std::sin(radians(40))), 0.0f,
                                  static_cast<float>(std::cos(radians(40)))};
  s.normal.at<cv::Vec3f>(0, 1) = {static_cast<float>(-std::sin(radians(80))), 0.0f,
                                  static_cast<float>(std::cos(radians(80)))};
  DistantLight light;
  light.direction = light_direction(0.0, 30.0);
  const cv::Mat img = render_lambertian(s, light, false);
  EXPECT_NEAR(img.at<cv::Vec3f>(0, 0)[1], 0.5 * std::cos(radians(10)), 1e-6);
  EXPECT_EQ(img.at<cv::Vec3f>(0, 1), cv::Vec3f(0, 0, 0));  // 110 deg from the light
}

TEST(LambertRenderTest, RendersARealSwatchWithinItsAlbedo) {
  const Swatch s = swatch_of("jersey", {200, 150});
  DistantLight light;
  light.direction = light_direction(120.0, 45.0);
  const cv::Mat img = render_lambertian(s, light);
  cv::Mat over;
  cv::compare(img, s.albedo, over, cv::CMP_GT);
  EXPECT_EQ(cv::countNonZero(over.reshape(1)), 0);
  double lo = 0;
  cv::minMaxLoc(img.reshape(1), &lo);
  EXPECT_GE(lo, 0.0);
  EXPECT_GT(cv::mean(img)[0], 0.02);
}

// ---------------------------------------------------------------- shadows

// A tall box standing on a flat floor.
Swatch box_swatch(double height_mm, double px) {
  Swatch s = flat_swatch({200, 200}, {0.5f, 0.5f, 0.5f}, px);
  s.height_mm(cv::Rect(120, 80, 40, 40)).setTo(height_mm);
  return s;
}

int run_length(const cv::Mat& mask, int r, int c, int dr, int dc) {
  int n = 0;
  while (r >= 0 && r < mask.rows && c >= 0 && c < mask.cols && mask.at<std::uint8_t>(r, c) != 0) {
    ++n;
    r += dr;
    c += dc;
  }
  return n;
}

TEST(CastShadowTest, BoxLitFromPlusXShadowsItsMinusXSide) {
  const double h = 0.5;
  const double px = 0.01;
  const Swatch s = box_swatch(h, px);
  for (double slant : {20.0, 45.0, 60.0}) {
    const cv::Mat mask = cast_shadow_mask(s.height_mm, px, light_direction(0.0, slant));
    ASSERT_EQ(mask.type(), CV_8U);
    const double expected = h * std::tan(radians(slant)) / px;
    for (int r : {80, 100, 119}) {
      EXPECT_NEAR(run_length(mask, r, 119, 0, -1), expected, 1.0) << "slant " << slant;
    }
    // Nothing on the lit side, on the box's top, or beside the box's rows.
    EXPECT_EQ(cv::countNonZero(mask(cv::Rect(120, 0, 80, 200))), 0) << "slant " << slant;
    EXPECT_EQ(cv::countNonZero(mask(cv::Rect(0, 0, 200, 80))), 0) << "slant " << slant;
    EXPECT_EQ(cv::countNonZero(mask(cv::Rect(0, 120, 200, 80))), 0) << "slant " << slant;
  }
}

TEST(CastShadowTest, BoxLitFromPlusYShadowsTheRowsBelowIt) {
  // y is up: a light at tilt 90 deg is above the image's top edge, so the
  // shadow falls toward the bottom rows.
  const double h = 0.3;
  const double px = 0.01;
  const Swatch s = box_swatch(h, px);
  const cv::Mat mask = cast_shadow_mask(s.height_mm, px, light_direction(90.0, 45.0));
  EXPECT_NEAR(run_length(mask, 120, 140, 1, 0), h / px, 1.0);
  EXPECT_EQ(cv::countNonZero(mask(cv::Rect(0, 0, 200, 120))), 0);
}

TEST(CastShadowTest, OverheadLightCastsNone) {
  const Swatch box = box_swatch(0.5, 0.01);
  EXPECT_EQ(cv::countNonZero(cast_shadow_mask(box.height_mm, 0.01, {0, 0, 1})), 0);
  for (std::string_view pattern : kPatterns) {
    const Swatch s = swatch_of(pattern, {200, 150});
    EXPECT_EQ(cv::countNonZero(cast_shadow_mask(s.height_mm, s.pixel_size_mm, {0, 0, 2})), 0);
  }
}

TEST(CastShadowTest, RealSwatchesShadowMoreAsTheLightLowers) {
  const Swatch s = swatch_of("rib", {300, 200});
  const int high =
      cv::countNonZero(cast_shadow_mask(s.height_mm, s.pixel_size_mm, light_direction(30.0, 20.0)));
  const int low =
      cv::countNonZero(cast_shadow_mask(s.height_mm, s.pixel_size_mm, light_direction(30.0, 60.0)));
  EXPECT_LT(high, low);
  EXPECT_GT(low, 0);
}

TEST(CastShadowTest, RenderIsBlackInCastShadow) {
  const double px = 0.01;
  const Swatch s = box_swatch(0.5, px);
  DistantLight light;
  light.direction = light_direction(0.0, 45.0);
  const cv::Mat shadowed = render_lambertian(s, light, true);
  const cv::Mat unshadowed = render_lambertian(s, light, false);
  const float lit = static_cast<float>(0.5 * std::cos(radians(45.0)));
  EXPECT_EQ(shadowed.at<cv::Vec3f>(100, 100), cv::Vec3f(0, 0, 0));  // 20 px into the shadow
  EXPECT_NEAR(unshadowed.at<cv::Vec3f>(100, 100)[0], lit, 1e-6);
  EXPECT_NEAR(shadowed.at<cv::Vec3f>(100, 20)[0], lit, 1e-6);  // beyond the shadow's end
}

}  // namespace
}  // namespace psrig::sim
