// Woodham's solve on scenes with a known answer.

#include "psrig/processing/woodham.h"

#include <cmath>
#include <numbers>
#include <thread>

#include <gtest/gtest.h>

#include "psrig/base/parallel.h"
#include "psrig/formats/map_encoding.h"
#include "synthetic_scene.h"

namespace psrig::processing {
namespace {

using test::mean_angular_error_deg;
using test::render_scan;
using test::ring_lights;
using test::sphere_surface;

double valid_fraction(const cv::Mat& flags) {
  return cv::countNonZero(encode_valid_mask(flags)) /
         static_cast<double>(flags.total());
}

TEST(Woodham, SphereColour16BitNoiseFreeIsExact) {
  const auto surface = sphere_surface({160, 120}, 50, 3);
  const formats::Scan scan = render_scan(surface, ring_lights(3, 45), CV_16U);
  auto result = solve(scan);
  ASSERT_TRUE(result) << result.error().describe();
  const cv::Mat normals = normals_from_gradients(result->p, result->q);
  const cv::Mat valid = encode_valid_mask(result->flags);
  EXPECT_GT(cv::countNonZero(valid), 0.8 * valid.total());
  EXPECT_LT(mean_angular_error_deg(normals, surface.normal, valid), 0.05);

  // One normal, three albedos: each channel's albedo is recovered.
  cv::Mat albedo_error;
  cv::absdiff(result->albedo, surface.albedo, albedo_error);
  for (int c = 0; c < 3; ++c) {
    cv::Mat channel;
    cv::extractChannel(albedo_error, channel, c);
    double worst = 0;
    cv::minMaxLoc(channel, nullptr, &worst, nullptr, nullptr, valid);
    EXPECT_LT(worst, 2e-3) << "channel " << c;
  }
}

TEST(Woodham, SphereGreyFloatNoiseFree) {
  const auto surface = sphere_surface({101, 101}, 40, 1);
  const formats::Scan scan = render_scan(surface, ring_lights(3, 30, 15), CV_32F);
  auto result = solve(scan);
  ASSERT_TRUE(result);
  const cv::Mat valid = encode_valid_mask(result->flags);
  EXPECT_LT(
      mean_angular_error_deg(normals_from_gradients(result->p, result->q), surface.normal, valid),
      0.01);
  // Grey with three lights: the model fits exactly.
  double worst_residual = 0;
  cv::minMaxLoc(result->residual, nullptr, &worst_residual, nullptr, nullptr, valid);
  EXPECT_LT(worst_residual, 1e-5);
}

// With noise of standard deviation sigma per channel, the grey measurement
// of C channels has sigma / sqrt(C); t = L^-1 g gives cov(t) =
// sigma^2 / C (L^T L)^-1, and the angle error is the part of dt across the
// normal over |t| = rho. Per pixel E[theta^2] = sigma^2 / (C rho^2)
// tr(P (L^T L)^-1 P), P = I - n n^T. E|theta| lies between sqrt(2/pi) (one
// dominant direction) and 1 (Jensen) times that RMS.
TEST(Woodham, NoiseErrorMatchesDerivedBound) {
  const double sigma = 0.003;
  const int channels = 3;
  const auto lights = ring_lights(3, 45);
  const auto surface = sphere_surface({200, 160}, 70, channels);
  const formats::Scan scan = render_scan(surface, lights, CV_16U, sigma, 7);
  auto result = solve(scan);
  ASSERT_TRUE(result);
  const cv::Mat valid = encode_valid_mask(result->flags);
  const double measured =
      mean_angular_error_deg(normals_from_gradients(result->p, result->q), surface.normal, valid);

  double predicted = 0;
  int count = 0;
  for (int r = 0; r < valid.rows; ++r) {
    for (int c = 0; c < valid.cols; ++c) {
      if (!valid.at<std::uint8_t>(r, c)) continue;
      const cv::Vec3f a = surface.albedo.at<cv::Vec3f>(r, c);
      predicted += test::predicted_rms_angle(lights, surface.normal.at<cv::Vec3f>(r, c),
                                             (a[0] + a[1] + a[2]) / 3, sigma, channels);
      ++count;
    }
  }
  predicted = predicted / count * 180 / std::numbers::pi;
  EXPECT_LE(measured, 1.05 * predicted) << "predicted RMS " << predicted;
  EXPECT_GE(measured, 0.75 * predicted) << "predicted RMS " << predicted;
}

TEST(Woodham, LeastSquaresWithThreeLightsEqualsExactInverse) {
  const auto surface = sphere_surface({120, 90}, 35, 3);
  const formats::Scan scan = render_scan(surface, ring_lights(3, 40, 10), CV_16U, 0.01, 3);
  auto exact = solve(scan);
  SolveOptions options;
  options.force_least_squares = true;
  auto least_squares = solve(scan, options);
  ASSERT_TRUE(exact && least_squares);
  const cv::Mat valid = encode_valid_mask(exact->flags);
  EXPECT_EQ(cv::norm(exact->flags, least_squares->flags, cv::NORM_INF), 0);
  EXPECT_LT(cv::norm(exact->p, least_squares->p, cv::NORM_INF, valid), 1e-4);
  EXPECT_LT(cv::norm(exact->q, least_squares->q, cv::NORM_INF, valid), 1e-4);
  EXPECT_LT(cv::norm(exact->albedo, least_squares->albedo, cv::NORM_INF, valid), 1e-5);
  EXPECT_LT(cv::norm(exact->residual, least_squares->residual, cv::NORM_INF, valid), 1e-4);
}

TEST(Woodham, AttachedShadowsAreFlaggedWhereTheGeometrySaysSo) {
  const auto lights = ring_lights(3, 60);
  const auto surface = sphere_surface({160, 160}, 75, 1);
  auto result = solve(render_scan(surface, lights, CV_16U));
  ASSERT_TRUE(result);
  int wrong = 0, shadowed = 0;
  for (int r = 0; r < 160; ++r) {
    for (int c = 0; c < 160; ++c) {
      const cv::Vec3f n = surface.normal.at<cv::Vec3f>(r, c);
      double darkest = 1;
      for (const auto& l : lights)
        darkest = std::min(darkest, n[0] * l[0] + n[1] * l[1] + n[2] * l[2]);
      const bool flagged = result->flags.at<std::uint8_t>(r, c) & kShadowed;
      shadowed += flagged;
      if (darkest < 0.03 && !flagged) ++wrong;  // clearly in shadow of some light
      if (darkest > 0.07 && flagged) ++wrong;   // clearly lit by all
    }
  }
  EXPECT_GT(shadowed, 500);
  EXPECT_EQ(wrong, 0);
}

TEST(Woodham, SaturatedAndDarkPixelsAreFlaggedAndNotValid) {
  auto surface = sphere_surface({80, 60}, 25, 1);
  surface.albedo(cv::Rect(0, 0, 10, 10)).setTo(3.0);      // far above white
  surface.albedo(cv::Rect(70, 50, 10, 10)).setTo(0.002);  // barely any signal
  const formats::Scan scan = render_scan(surface, ring_lights(3, 45), CV_16U);
  auto result = solve(scan);
  ASSERT_TRUE(result);
  EXPECT_TRUE(result->flags.at<std::uint8_t>(5, 5) & kSaturated);
  EXPECT_FALSE(is_valid(result->flags.at<std::uint8_t>(5, 5)));
  EXPECT_TRUE(result->flags.at<std::uint8_t>(55, 75) & kLowSignal);
  EXPECT_EQ(result->p.at<float>(55, 75), 0.0f);
  EXPECT_TRUE(is_valid(result->flags.at<std::uint8_t>(30, 40)));
}

TEST(Woodham, MaskedPixelsAreNotSolved) {
  const auto surface = sphere_surface({80, 60}, 25, 3);
  formats::Scan scan = render_scan(surface, ring_lights(3, 45), CV_8U);
  scan.mask = cv::Mat(scan.size(), CV_8U, cv::Scalar(255));
  scan.mask(cv::Rect(0, 0, 40, 60)).setTo(0);
  auto result = solve(scan);
  ASSERT_TRUE(result);
  EXPECT_EQ(result->flags.at<std::uint8_t>(30, 20), kOutsideMask);
  EXPECT_EQ(result->p.at<float>(30, 20), 0.0f);
  EXPECT_EQ(result->albedo.at<cv::Vec3f>(30, 20), cv::Vec3f(0, 0, 0));
  EXPECT_TRUE(is_valid(result->flags.at<std::uint8_t>(30, 60)));
}

TEST(Woodham, PerLightRgbIntensityIsDividedOut) {
  const auto surface = sphere_surface({80, 60}, 25, 3);
  formats::Scan scan = render_scan(surface, ring_lights(3, 45), CV_32F);
  // Light 1 is twice as bright in red: its frame shows it, scan.json says it.
  std::vector<cv::Mat> planes;
  cv::split(scan.frames[1], planes);
  planes[2] *= 2;
  cv::merge(planes, scan.frames[1]);
  scan.description.lights[1].intensity_bgr = {1, 1, 2};
  auto result = solve(scan);
  ASSERT_TRUE(result);
  const cv::Mat valid = encode_valid_mask(result->flags);
  EXPECT_LT(
      mean_angular_error_deg(normals_from_gradients(result->p, result->q), surface.normal, valid),
      0.01);
  EXPECT_LT(cv::norm(result->albedo, surface.albedo, cv::NORM_INF, valid), 1e-4);
}

TEST(Woodham, RejectionBeatsLeastSquaresUnderCastShadows) {
  const cv::Size size(200, 200);
  const double radius = 45;
  const auto lights = ring_lights(6, 60);
  const auto surface = test::dome_surface(size, radius, 1);
  std::vector<cv::Mat> shadows;
  cv::Mat any_shadow(size, CV_8U, cv::Scalar(0));
  for (const auto& l : lights) {
    shadows.push_back(test::dome_cast_shadow(size, radius, l));
    any_shadow |= shadows.back();
  }
  ASSERT_GT(cv::countNonZero(any_shadow), 3000);
  const formats::Scan scan = render_scan(surface, lights, CV_16U, 0.0005, 11, shadows);

  auto plain = solve(scan);
  SolveOptions options;
  options.reject_outliers = true;
  auto rejecting = solve(scan, options);
  ASSERT_TRUE(plain && rejecting);
  const double plain_error = mean_angular_error_deg(normals_from_gradients(plain->p, plain->q),
                                                    surface.normal, any_shadow);
  const double rejecting_error = mean_angular_error_deg(
      normals_from_gradients(rejecting->p, rejecting->q), surface.normal, any_shadow);
  EXPECT_GT(plain_error, 5.0);
  EXPECT_LT(rejecting_error, 0.5);
  // Cast-shadowed pixels are solved from the other lights and count as valid.
  EXPECT_GT(valid_fraction(rejecting->flags), valid_fraction(plain->flags));
  // A plane pixel just right of the dome, in some light's cast shadow:
  // recovered by rejection, valid; least squares leaves it shadowed.
  const int r = 100, c = 100 + static_cast<int>(radius) + 5;
  ASSERT_TRUE(any_shadow.at<std::uint8_t>(r, c));
  EXPECT_TRUE(rejecting->flags.at<std::uint8_t>(r, c) & kRecovered);
  EXPECT_TRUE(is_valid(rejecting->flags.at<std::uint8_t>(r, c)));
  EXPECT_FALSE(is_valid(plain->flags.at<std::uint8_t>(r, c)));
}

// Rejection only vouches for a pixel when what is left is sound: with four
// lights, one saturated and one shadowed, three remain after dropping the
// saturated one, and the shadowed one cannot go too. Not valid.
TEST(Woodham, RejectionDoesNotVouchForADoubtfulRemainder) {
  const auto lights = ring_lights(4, 45);
  const test::Surface plane{cv::Mat(8, 8, CV_32FC3, cv::Scalar(0, 0, 1)),
                            cv::Mat(8, 8, CV_32F, cv::Scalar(0.5))};
  formats::Scan scan = render_scan(plane, lights, CV_32F);
  scan.frames[0].setTo(2.0);  // above white (1.0): saturated
  scan.frames[1].setTo(0.0);  // blocked: shadowed
  auto result = solve(scan, {.reject_outliers = true});
  ASSERT_TRUE(result);
  const std::uint8_t flags = result->flags.at<std::uint8_t>(4, 4);
  EXPECT_TRUE(flags & kSaturated);
  EXPECT_TRUE(flags & kShadowed);
  EXPECT_FALSE(is_valid(flags));
  // With only the shadowed light gone, the other three are sound: valid.
  formats::Scan shadowed_only = render_scan(plane, lights, CV_32F);
  shadowed_only.frames[1].setTo(0.0);
  auto recovered = solve(shadowed_only, {.reject_outliers = true});
  ASSERT_TRUE(recovered);
  EXPECT_TRUE(is_valid(recovered->flags.at<std::uint8_t>(4, 4)));
  EXPECT_NEAR(recovered->p.at<float>(4, 4), 0.0f, 1e-5);
}

// Float frames can hold NaN or infinity (a dead pixel, a bad converter):
// such pixels are not solved, and every output stays finite.
TEST(Woodham, NonFiniteMeasurementsGiveFiniteOutputs) {
  for (int lights : {3, 5}) {
    const auto surface = sphere_surface({20, 10}, 6, 3);
    formats::Scan scan = render_scan(surface, ring_lights(lights, 45), CV_32F);
    scan.frames[1].at<cv::Vec3f>(5, 5) = cv::Vec3f(std::nanf(""), 0.3f, 0.3f);
    scan.frames[0].at<cv::Vec3f>(2, 2) = cv::Vec3f(INFINITY, INFINITY, INFINITY);
    scan.mask = cv::Mat(scan.size(), CV_8U, cv::Scalar(255));
    scan.mask.at<std::uint8_t>(5, 6) = 0;
    scan.frames[2].at<cv::Vec3f>(5, 6) = cv::Vec3f(std::nanf(""), 0, 0);  // masked and NaN
    for (const bool reject : {false, true}) {
      auto result = solve(scan, {.reject_outliers = reject});
      ASSERT_TRUE(result);
      for (const cv::Mat* m : {&result->p, &result->q, &result->albedo, &result->residual})
        EXPECT_TRUE(cv::checkRange(*m)) << lights << " lights, reject " << reject;
      EXPECT_FALSE(is_valid(result->flags.at<std::uint8_t>(5, 5)));
      EXPECT_EQ(result->flags.at<std::uint8_t>(5, 6), kOutsideMask);
    }
  }
}

TEST(Woodham, ResultsDoNotDependOnThreadCount) {
  if (std::thread::hardware_concurrency() < 2)
    GTEST_SKIP() << "one hardware thread: nothing to compare";
  const auto surface = sphere_surface({333, 97}, 40, 3);
  // Three lights (the exact inverse), five with rejection (ranks by
  // passes), seventy glossy ones with rejection (ranks by sorting).
  const std::vector<std::pair<formats::Scan, SolveOptions>> cases = {
      {render_scan(surface, ring_lights(3, 45), CV_16U, 0.01, 5), {}},
      {render_scan(surface, ring_lights(5, 50), CV_16U, 0.01, 5), {.reject_outliers = true}},
      {render_scan(surface, test::dome_lights(70, 55), CV_16U, 0.01, 5, {},
                   {.strength = 0.5, .exponent = 40}),
       {.reject_outliers = true}}};
  std::vector<SolveResult> results;
  for (int threads : {1, 2, 3}) {
    set_thread_count(threads);
    for (const auto& [scan, options] : cases) {
      auto result = solve(scan, options);
      ASSERT_TRUE(result);
      results.push_back(*result);
    }
  }
  set_thread_count(0);
  for (std::size_t i = cases.size(); i < results.size(); ++i) {
    const auto& a = results[i % cases.size()];
    const auto& b = results[i];
    EXPECT_EQ(cv::norm(a.p, b.p, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(a.q, b.q, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(a.albedo, b.albedo, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(a.residual, b.residual, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(a.flags, b.flags, cv::NORM_INF), 0);
  }
}

// The pipeline solves a band of rows at a time, into views of its planes
// and into band-sized buffers: the very values of the whole solve, for the
// three-light kernel (with a dark frame and a mask) and the general one.
TEST(Woodham, SolvedBandByBandEqualsSolvedWhole) {
  const auto surface = sphere_surface({131, 97}, 40, 3);
  formats::Scan three = render_scan(surface, ring_lights(3, 45), CV_16U, 0.01, 5);
  three.dark = cv::Mat(three.size(), three.frames[0].type(), cv::Scalar::all(300));
  for (auto& frame : three.frames)
    frame += three.dark;
  three.mask = cv::Mat(three.size(), CV_8U, cv::Scalar(255));
  three.mask(cv::Rect(10, 12, 25, 20)).setTo(0);
  const formats::Scan five = render_scan(surface, ring_lights(5, 50), CV_16U, 0.01, 5);
  const std::vector<std::pair<const formats::Scan*, SolveOptions>> cases = {
      {&three, {}}, {&five, {.reject_outliers = true}}};
  for (const auto& [scan, options] : cases) {
    auto whole = solve(*scan, options);
    ASSERT_TRUE(whole);
    auto solver = RowSolver::create(*scan, options);
    ASSERT_TRUE(solver);
    SolveResult views;  // into whole-size planes
    views.p.create(scan->size(), CV_32F);
    views.q.create(scan->size(), CV_32F);
    views.albedo.create(scan->size(), CV_32FC3);
    views.residual.create(scan->size(), CV_32F);
    views.flags.create(scan->size(), CV_8U);
    for (int first = 0; first < scan->size().height; first += 23) {
      const int rows = std::min(23, scan->size().height - first);
      SolveResult band;  // band-sized, made by the solver
      solver->solve(first, rows, band);
      SolveResult view{views.p.rowRange(first, first + rows), views.q.rowRange(first, first + rows),
                       views.albedo.rowRange(first, first + rows),
                       views.residual.rowRange(first, first + rows),
                       views.flags.rowRange(first, first + rows)};
      solver->solve(first, rows, view);
      EXPECT_EQ(view.p.data, views.p.ptr(first));  // stayed a view
      EXPECT_EQ(cv::norm(band.albedo, whole->albedo.rowRange(first, first + rows), cv::NORM_INF),
                0);
    }
    EXPECT_EQ(cv::norm(views.p, whole->p, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(views.q, whole->q, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(views.albedo, whole->albedo, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(views.residual, whole->residual, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(views.flags, whole->flags, cv::NORM_INF), 0);
  }
}

}  // namespace
}  // namespace psrig::processing
