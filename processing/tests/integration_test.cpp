// Normal integration: Frankot–Chellappa (r2r, mirror extension) and the DCT
// Poisson solver. Axes as docs/design.md: x = column, y up (y = -row + const),
// p = dz/dx, q = dz/dy, so dz/drow = -q.

#include "psrig/processing/integration.h"

#include <cmath>
#include <complex>
#include <cstdio>
#include <limits>
#include <numbers>
#include <random>
#include <thread>
#include <vector>

#include <fftw3.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "psrig/base/error.h"
#include "psrig/base/parallel.h"
#include "test_support.h"

namespace psrig::processing {
namespace {

using Field = std::vector<double>;  // row-major height x width

struct Gradients {
  cv::Mat z;  // CV_64F, the truth (any constant)
  cv::Mat p;  // CV_32F
  cv::Mat q;  // CV_32F
};

// A smooth, non-periodic surface with analytic gradients: a tilted plane, a
// quadratic with a cross term, and Gaussian bumps, two of them cut by the
// borders. Nothing about it is symmetric about the image edges.
Gradients analytic_surface(int width, int height) {
  struct Bump {
    double x, y, sigma, amplitude;
  };
  const Bump bumps[] = {{40.0, 30.0, 9.0, 6.0},
                        {110.0, 80.0, 14.0, -4.0},
                        {155.0, 10.0, 12.0, 5.0},
                        {5.0, 115.0, 10.0, 3.0}};
  Gradients g{cv::Mat(height, width, CV_64F), cv::Mat(height, width, CV_32F),
              cv::Mat(height, width, CV_32F)};
  for (int row = 0; row < height; ++row) {
    for (int col = 0; col < width; ++col) {
      const double x = col;
      const double y = height - 1 - row;  // y up
      const double dx = x - 70.0;
      const double dy = y - 50.0;
      double z = 0.06 * x - 0.09 * y + 4e-4 * dx * dx - 3e-4 * dx * dy + 5e-4 * dy * dy;
      double zx = 0.06 + 8e-4 * dx - 3e-4 * dy;
      double zy = -0.09 - 3e-4 * dx + 1e-3 * dy;
      for (const Bump& b : bumps) {
        const double ex = x - b.x;
        const double ey = y - b.y;
        const double s2 = b.sigma * b.sigma;
        const double e = b.amplitude * std::exp(-(ex * ex + ey * ey) / (2.0 * s2));
        z += e;
        zx += -ex / s2 * e;
        zy += -ey / s2 * e;
      }
      g.z.at<double>(row, col) = z;
      g.p.at<float>(row, col) = static_cast<float>(zx);
      g.q.at<float>(row, col) = static_cast<float>(zy);
    }
  }
  return g;
}

// RMS of (estimate - truth) over the pixels where `mask` is non-zero (all
// pixels when mask is empty), after removing the mean difference there.
double rms_error(const cv::Mat& estimate, const cv::Mat& truth, const cv::Mat& mask = {}) {
  cv::Mat e;
  cv::Mat t;
  estimate.convertTo(e, CV_64F);
  truth.convertTo(t, CV_64F);
  const cv::Mat d = e - t;
  const double mean = cv::mean(d, mask)[0];
  double sum = 0.0;
  int count = 0;
  for (int row = 0; row < d.rows; ++row)
    for (int col = 0; col < d.cols; ++col)
      if (mask.empty() || mask.at<uchar>(row, col) != 0) {
        const double r = d.at<double>(row, col) - mean;
        sum += r * r;
        ++count;
      }
  return std::sqrt(sum / count);
}

cv::Mat random_field(int width, int height, unsigned seed, float amplitude = 1.0F) {
  cv::Mat m(height, width, CV_32F);
  std::mt19937 engine(seed);
  std::uniform_real_distribution<float> uniform(-amplitude, amplitude);
  for (int row = 0; row < height; ++row)
    for (int col = 0; col < width; ++col)
      m.at<float>(row, col) = uniform(engine);
  return m;
}

// Restores the thread count a test changed.
class ThreadCountGuard {
 public:
  ThreadCountGuard() : saved_(thread_count()) {}
  ~ThreadCountGuard() { set_thread_count(saved_); }
  ThreadCountGuard(const ThreadCountGuard&) = delete;
  ThreadCountGuard& operator=(const ThreadCountGuard&) = delete;

 private:
  int saved_;
};

TEST(IntegrationMethod, ParsesAndPrintsEveryName) {
  for (const auto method : {IntegrationMethod::frankot_chellappa, IntegrationMethod::poisson,
                            IntegrationMethod::none}) {
    const auto parsed = parse_integration_method(to_string(method));
    ASSERT_TRUE(parsed.has_value()) << to_string(method);
    EXPECT_EQ(*parsed, method);
  }
  EXPECT_EQ(to_string(IntegrationMethod::frankot_chellappa), "fc");
  EXPECT_EQ(to_string(IntegrationMethod::poisson), "poisson");
  EXPECT_EQ(to_string(IntegrationMethod::none), "none");
  EXPECT_FALSE(parse_integration_method("FC").has_value());
  EXPECT_FALSE(parse_integration_method("").has_value());
  EXPECT_FALSE(parse_integration_method("frankot").has_value());
}

TEST(Integration, RejectsBadInputs) {
  const cv::Mat good(8, 10, CV_32F, cv::Scalar(0.1));
  const cv::Mat empty;
  const cv::Mat other_size(8, 11, CV_32F, cv::Scalar(0.1));
  const cv::Mat doubles(8, 10, CV_64F, cv::Scalar(0.1));
  const cv::Mat two_channels(8, 10, CV_32FC2, cv::Scalar(0.1, 0.1));
  const cv::Mat bytes(8, 10, CV_8U, cv::Scalar(1));
  const std::pair<const cv::Mat*, const cv::Mat*> cases[] = {
      {&empty, &good},   {&good, &empty},   {&empty, &empty},       {&good, &other_size},
      {&doubles, &good}, {&good, &doubles}, {&two_channels, &good}, {&good, &bytes},
  };
  for (const auto method : {IntegrationMethod::frankot_chellappa, IntegrationMethod::poisson}) {
    int index = 0;
    for (const auto& [p, q] : cases) {
      const auto result = integrate(method, *p, *q);
      ASSERT_FALSE(result.has_value()) << to_string(method) << " case " << index;
      EXPECT_EQ(result.error().kind, ErrorKind::bad_input) << result.error().describe();
      EXPECT_FALSE(result.error().message.empty());
      ++index;
    }
  }
  const auto result = integrate_frankot_chellappa(good, other_size);
  ASSERT_FALSE(result.has_value());
  EXPECT_NE(result.error().message.find("10x8"), std::string::npos) << result.error().message;
  EXPECT_NE(result.error().message.find("11x8"), std::string::npos) << result.error().message;
}

TEST(Integration, NoneReturnsEmptyAndDispatchMatchesDirectCalls) {
  const cv::Mat p = random_field(20, 14, 1);
  const cv::Mat q = random_field(20, 14, 2);
  const auto none = integrate(IntegrationMethod::none, p, q);
  ASSERT_TRUE(none.has_value());
  EXPECT_TRUE(none->empty());

  const auto fc = integrate(IntegrationMethod::frankot_chellappa, p, q);
  const auto fc_direct = integrate_frankot_chellappa(p, q);
  const auto poisson = integrate(IntegrationMethod::poisson, p, q);
  const auto poisson_direct = integrate_poisson(p, q);
  ASSERT_TRUE(fc && fc_direct && poisson && poisson_direct);
  EXPECT_EQ(cv::norm(*fc, *fc_direct, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(*poisson, *poisson_direct, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(*fc, *poisson, cv::NORM_INF), 0.0);  // two different methods
}

TEST(Integration, OutputIsFloatSameSizeZeroMean) {
  const cv::Mat p = random_field(37, 23, 3);
  const cv::Mat q = random_field(37, 23, 4);
  for (const auto method : {IntegrationMethod::frankot_chellappa, IntegrationMethod::poisson}) {
    const auto z = integrate(method, p, q);
    ASSERT_TRUE(z.has_value()) << z.error().describe();
    EXPECT_EQ(z->type(), CV_32FC1);
    EXPECT_EQ(z->size(), p.size());
    double max_abs = 0.0;
    cv::minMaxLoc(cv::abs(*z), nullptr, &max_abs);
    EXPECT_GT(max_abs, 0.1);
    EXPECT_LT(std::abs(cv::mean(*z)[0]), 1e-6 * max_abs) << to_string(method);
  }
}

TEST(Integration, HandlesDegenerateSizes) {
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(1, 7), cv::Size(7, 1), cv::Size(2, 2)}) {
    const cv::Mat p = random_field(size.width, size.height, 5);
    const cv::Mat q = random_field(size.width, size.height, 6);
    for (const auto method : {IntegrationMethod::frankot_chellappa, IntegrationMethod::poisson}) {
      const auto z = integrate(method, p, q);
      ASSERT_TRUE(z.has_value()) << z.error().describe();
      EXPECT_EQ(z->size(), size);
      EXPECT_TRUE(cv::checkRange(*z)) << to_string(method) << " " << size;
      EXPECT_LT(std::abs(cv::mean(*z)[0]), 1e-6);
    }
  }
}

TEST(Integration, SingleRowPoissonIsExactForAConstantSlope) {
  // One row: only pbar matters, and a constant p gives pbar = p exactly.
  const cv::Mat p(1, 9, CV_32F, cv::Scalar(0.5));
  const cv::Mat q(1, 9, CV_32F, cv::Scalar(7.0));  // no row differences to fit
  const auto z = integrate_poisson(p, q);
  ASSERT_TRUE(z.has_value());
  for (int col = 0; col < 9; ++col)
    EXPECT_NEAR(z->at<float>(0, col), 0.5 * (col - 4), 1e-5);
}

TEST(Integration, NonFiniteGradientsCountAsZero) {
  cv::Mat p = random_field(30, 20, 7);
  cv::Mat q = random_field(30, 20, 8);
  cv::Mat p_bad = p.clone();
  cv::Mat q_bad = q.clone();
  p.at<float>(3, 4) = 0.0F;
  p_bad.at<float>(3, 4) = std::numeric_limits<float>::quiet_NaN();
  q.at<float>(0, 29) = 0.0F;
  q_bad.at<float>(0, 29) = std::numeric_limits<float>::infinity();
  q.at<float>(19, 0) = 0.0F;
  q_bad.at<float>(19, 0) = -std::numeric_limits<float>::infinity();
  for (const auto method : {IntegrationMethod::frankot_chellappa, IntegrationMethod::poisson}) {
    const auto clean = integrate(method, p, q);
    const auto dirty = integrate(method, p_bad, q_bad);
    ASSERT_TRUE(clean && dirty);
    EXPECT_TRUE(cv::checkRange(*dirty));
    EXPECT_EQ(cv::norm(*clean, *dirty, cv::NORM_INF), 0.0) << to_string(method);
  }
}

TEST(Integration, AcceptsNonContinuousViews) {
  const cv::Mat big_p = random_field(50, 40, 9);
  const cv::Mat big_q = random_field(50, 40, 10);
  const cv::Rect roi(3, 5, 31, 22);
  const cv::Mat p = big_p(roi);
  const cv::Mat q = big_q(roi);
  ASSERT_FALSE(p.isContinuous());
  for (const auto method : {IntegrationMethod::frankot_chellappa, IntegrationMethod::poisson}) {
    const auto view = integrate(method, p, q);
    const auto copy = integrate(method, p.clone(), q.clone());
    ASSERT_TRUE(view && copy);
    EXPECT_EQ(cv::norm(*view, *copy, cv::NORM_INF), 0.0) << to_string(method);
  }
}

// ---------------------------------------------------------------------------
// Frankot–Chellappa against the literal computation: mirror-extend p and q
// to 2W x 2H (z even about every border: p odd in x and even in y, q even in
// x and odd in y), take the complex 2-D FFT, apply the textbook formula
// Z = -i (u P + v Q) / (u^2 + v^2) with Z(0, 0) = 0, invert, and keep the
// top-left W x H block.
//
// Frequencies: u = 2 pi k / (2W) with k folded to -W..W-1 (so the Nyquist
// column has u = -pi); along the rows the DFT frequency is w = 2 pi l / (2H)
// folded likewise, and since y = -row, v = -w. The Nyquist column and row are
// kept, as an FFT-based FC would: the mirror-extended q is even in x, so Q's
// Nyquist column is zero, and p is even in y, so P's Nyquist row is zero.
// What remains on the Nyquist column, -i u P / (u^2 + v^2), is at (l, W) the
// negated conjugate of its value at (-l, W) (P is Hermitian there and u is
// the same), so each pair inverts to a purely imaginary term; likewise on
// the Nyquist row. So the real part of the result does not depend on those
// terms, nor on the sign given to the Nyquist frequency. The r2r
// implementation never forms them (the DCT-II of an even-extended z has no
// Nyquist coefficient), and the two agree on the real part.
// With mirror = false the same formula runs on the field as it is, treated
// as periodic: the plain FFT method, kept to show the wrap-around it suffers.
cv::Mat literal_fft_fc(const cv::Mat& p, const cv::Mat& q, bool mirror = true) {
  const int w = p.cols;
  const int h = p.rows;
  const int ew = mirror ? 2 * w : w;
  const int eh = mirror ? 2 * h : h;
  auto* pe = fftwf_alloc_complex(static_cast<std::size_t>(ew) * eh);
  auto* qe = fftwf_alloc_complex(static_cast<std::size_t>(ew) * eh);
  for (int r = 0; r < eh; ++r) {
    const int sr = r < h ? r : eh - 1 - r;
    const float sign_y = r < h ? 1.0F : -1.0F;
    for (int c = 0; c < ew; ++c) {
      const int sc = c < w ? c : ew - 1 - c;
      const float sign_x = c < w ? 1.0F : -1.0F;
      const std::size_t i = static_cast<std::size_t>(r) * ew + c;
      pe[i][0] = sign_x * p.at<float>(sr, sc);  // odd in x, even in y
      pe[i][1] = 0.0F;
      qe[i][0] = sign_y * q.at<float>(sr, sc);  // even in x, odd in y
      qe[i][1] = 0.0F;
    }
  }
  fftwf_plan forward_p = fftwf_plan_dft_2d(eh, ew, pe, pe, FFTW_FORWARD, FFTW_ESTIMATE);
  fftwf_plan forward_q = fftwf_plan_dft_2d(eh, ew, qe, qe, FFTW_FORWARD, FFTW_ESTIMATE);
  fftwf_plan backward = fftwf_plan_dft_2d(eh, ew, pe, pe, FFTW_BACKWARD, FFTW_ESTIMATE);
  fftwf_execute(forward_p);
  fftwf_execute(forward_q);
  for (int l = 0; l < eh; ++l) {
    const int lf = l < (eh + 1) / 2 ? l : l - eh;  // mirrored: Nyquist row -> -h
    const double v = -2.0 * std::numbers::pi * lf / eh;
    for (int k = 0; k < ew; ++k) {
      const int kf = k < (ew + 1) / 2 ? k : k - ew;
      const double u = 2.0 * std::numbers::pi * kf / ew;
      const std::size_t i = static_cast<std::size_t>(l) * ew + k;
      std::complex<double> z = 0.0;
      if (l != 0 || k != 0) {
        const std::complex<double> pp(pe[i][0], pe[i][1]);
        const std::complex<double> qq(qe[i][0], qe[i][1]);
        z = std::complex<double>(0.0, -1.0) * (u * pp + v * qq) / (u * u + v * v);
      }
      pe[i][0] = static_cast<float>(z.real());
      pe[i][1] = static_cast<float>(z.imag());
    }
  }
  fftwf_execute(backward);
  cv::Mat z(h, w, CV_32F);
  const double norm = 1.0 / (static_cast<double>(ew) * eh);
  for (int r = 0; r < h; ++r)
    for (int c = 0; c < w; ++c)
      z.at<float>(r, c) = static_cast<float>(pe[static_cast<std::size_t>(r) * ew + c][0] * norm);
  fftwf_destroy_plan(forward_p);
  fftwf_destroy_plan(forward_q);
  fftwf_destroy_plan(backward);
  fftwf_free(pe);
  fftwf_free(qe);
  return z;
}

TEST(IntegrationFrankotChellappa, MatchesLiteralMirrorExtendedFft) {
  // Random, far from integrable fields exercise every frequency; odd and
  // even sizes, square and not.
  for (const cv::Size size : {cv::Size(24, 18), cv::Size(17, 11), cv::Size(16, 16)}) {
    const cv::Mat p = random_field(size.width, size.height, 11);
    const cv::Mat q = random_field(size.width, size.height, 12);
    const cv::Mat expected = literal_fft_fc(p, q);
    const auto z = integrate_frankot_chellappa(p, q);
    ASSERT_TRUE(z.has_value()) << z.error().describe();
    double scale = 0.0;
    cv::minMaxLoc(cv::abs(expected), nullptr, &scale);
    ASSERT_GT(scale, 0.1);
    // Float transforms of a few hundred points: a few ulps of the range.
    EXPECT_LT(cv::norm(*z, expected, cv::NORM_INF), 2e-6 * scale) << size;
    std::printf("  [measured] FC vs literal FFT %dx%d: max diff %.3g of range %.3g\n", size.width,
                size.height, cv::norm(*z, expected, cv::NORM_INF), scale);
  }
}

TEST(IntegrationFrankotChellappa, MirroredFieldHasNoWrapAroundAndSignsMatch) {
  // A single plane z = a x + b y: a plain periodic FFT would bend it into a
  // sawtooth; the mirror extension gets it right up to the grid-level
  // spectral error at the borders. Also pins the signs: a wrong sign on q
  // would tilt the result the other way.
  const int w = 40;
  const int h = 30;
  cv::Mat p(h, w, CV_32F, cv::Scalar(0.25));
  cv::Mat q(h, w, CV_32F, cv::Scalar(-0.4));
  cv::Mat truth(h, w, CV_64F);
  for (int r = 0; r < h; ++r)
    for (int c = 0; c < w; ++c)
      truth.at<double>(r, c) = 0.25 * c - 0.4 * (h - 1 - r);
  for (const auto method : {IntegrationMethod::frankot_chellappa, IntegrationMethod::poisson}) {
    const auto z = integrate(method, p, q);
    ASSERT_TRUE(z.has_value());
    const double rms = rms_error(*z, truth);
    std::printf("  [measured] plane, %s: rms %.3g\n", std::string(to_string(method)).c_str(), rms);
    // z spans 0.25 * 39 + 0.4 * 29 = 21.35. Poisson is exact for a plane
    // (pbar = p = the forward difference): measured 5e-7. FC's spectral
    // derivative of the mirrored step in p rings at the borders: measured
    // 0.018, about 0.1% of the span.
    EXPECT_LT(rms, method == IntegrationMethod::poisson ? 1e-5 : 0.03) << to_string(method);
    // The slope across the middle row and column has the right sign and size.
    EXPECT_NEAR(z->at<float>(h / 2, w - 5) - z->at<float>(h / 2, 4), 0.25 * (w - 9), 0.05);
    EXPECT_NEAR(z->at<float>(4, w / 2) - z->at<float>(h - 5, w / 2), -0.4 * (h - 9), 0.05);
  }
}

TEST(Integration, RecoversAnAnalyticNonPeriodicSurface) {
  const int w = 160;
  const int h = 120;
  const Gradients g = analytic_surface(w, h);
  // A band of 8 pixels along every border, where wrap-around error would
  // concentrate, and the rest.
  cv::Mat border(h, w, CV_8U, cv::Scalar(255));
  border(cv::Rect(8, 8, w - 16, h - 16)).setTo(0);
  const cv::Mat interior = 255 - border;
  double z_min = 0.0;
  double z_max = 0.0;
  cv::minMaxLoc(g.z, &z_min, &z_max);
  ASSERT_GT(z_max - z_min, 20.0);

  // Bounds are the measured figures (in the comments, Release, x86-64) with
  // about 2x margin. The methods' own errors, not float rounding, set them:
  // - Poisson fits pbar = (p[j] + p[j+1]) / 2 to z[j+1] - z[j], which differ
  //   by z'''/12 per edge (trapezoid rule); with the bumps' z''' up to about
  //   A/sigma^3 = 6/9^3 = 0.008 that is ~7e-4 per edge, spread evenly:
  //   measured rms 9.6e-4 (border 8.4e-4).
  // - FC differentiates spectrally the mirror-extended field, whose gradient
  //   jumps at the borders (p != 0 there, so its odd extension has a step):
  //   a Gibbs-like error mostly in the border band: measured rms 2.3e-3
  //   (border 4.8e-3, interior 5.6e-4).
  // A periodic FFT without the mirror sees height jumps of ~10 across the
  // wrap: measured rms 5.9 in the border band, 3.9 inside, 1000x FC's.
  const auto fc = integrate_frankot_chellappa(g.p, g.q);
  const auto poisson = integrate_poisson(g.p, g.q);
  ASSERT_TRUE(fc && poisson);
  const cv::Mat periodic = literal_fft_fc(g.p, g.q, /*mirror=*/false);

  const double fc_rms = rms_error(*fc, g.z);
  const double fc_border = rms_error(*fc, g.z, border);
  const double fc_interior = rms_error(*fc, g.z, interior);
  const double poisson_rms = rms_error(*poisson, g.z);
  const double poisson_border = rms_error(*poisson, g.z, border);
  const double periodic_border = rms_error(periodic, g.z, border);
  std::printf(
      "  [measured] analytic: range %.3g; fc rms %.3g (border %.3g, interior %.3g); poisson rms "
      "%.3g (border %.3g); periodic FFT border %.3g, interior %.3g\n",
      z_max - z_min, fc_rms, fc_border, fc_interior, poisson_rms, poisson_border, periodic_border,
      rms_error(periodic, g.z, interior));
  EXPECT_LT(fc_rms, 5e-3);
  EXPECT_LT(fc_border, 1e-2);
  EXPECT_LT(fc_interior, 1.5e-3);
  EXPECT_LT(poisson_rms, 2e-3);
  EXPECT_LT(poisson_border, 2e-3);
  // No wrap-around: FC's border error is a tiny fraction of a periodic FFT's.
  EXPECT_LT(100.0 * fc_border, periodic_border);
}

// ---------------------------------------------------------------------------
// Poisson.

// Given z on the grid, gradients whose half-pixel averages equal the forward
// differences exactly: pbar[i][j] = (p[i][j] + p[i][j+1]) / 2 = z[i][j+1] -
// z[i][j], by the recurrence p[j+1] = 2 (z[j+1] - z[j]) - p[j]; the same down
// the rows for g = -q. Then z minimises the least-squares energy with
// residual zero, so the solver must return z itself (less its mean), up to
// float rounding of p, q and of the transforms.
Gradients exact_discrete_gradients(const cv::Mat& z) {
  Gradients g{z, cv::Mat(z.size(), CV_32F), cv::Mat(z.size(), CV_32F)};
  for (int r = 0; r < z.rows; ++r) {
    double previous = z.cols > 1 ? z.at<double>(r, 1) - z.at<double>(r, 0) : 0.0;
    g.p.at<float>(r, 0) = static_cast<float>(previous);
    for (int c = 0; c + 1 < z.cols; ++c) {
      previous = 2.0 * (z.at<double>(r, c + 1) - z.at<double>(r, c)) - previous;
      g.p.at<float>(r, c + 1) = static_cast<float>(previous);
    }
  }
  for (int c = 0; c < z.cols; ++c) {
    double previous = z.rows > 1 ? z.at<double>(1, c) - z.at<double>(0, c) : 0.0;  // g = -q
    g.q.at<float>(0, c) = static_cast<float>(-previous);
    for (int r = 0; r + 1 < z.rows; ++r) {
      previous = 2.0 * (z.at<double>(r + 1, c) - z.at<double>(r, c)) - previous;
      g.q.at<float>(r + 1, c) = static_cast<float>(-previous);
    }
  }
  return g;
}

TEST(IntegrationPoisson, IsExactForDiscretelyIntegrableGradients) {
  const int w = 90;
  const int h = 70;
  cv::Mat z(h, w, CV_64F);
  std::mt19937 engine(13);
  std::uniform_real_distribution<double> noise(-0.5, 0.5);
  for (int r = 0; r < h; ++r)
    for (int c = 0; c < w; ++c)
      z.at<double>(r, c) =
          5.0 * std::sin(0.07 * c + 0.3) * std::cos(0.05 * r) + 0.02 * c * r / 10.0 + noise(engine);
  const Gradients g = exact_discrete_gradients(z);
  const auto result = integrate_poisson(g.p, g.q);
  ASSERT_TRUE(result.has_value());
  cv::Mat expected;
  z.convertTo(expected, CV_32F, 1.0, -cv::mean(z)[0]);
  double scale = 0.0;
  cv::minMaxLoc(cv::abs(expected), nullptr, &scale);
  const double error = cv::norm(*result, expected, cv::NORM_INF);
  std::printf("  [measured] Poisson exactness: max error %.3g of range %.3g\n", error, scale);
  EXPECT_LT(error, 2e-6 * scale);  // measured 4.3e-6 on a range of 11.3
}

TEST(IntegrationPoisson, SolvesTheNormalEquations) {
  // For any field, integrable or not, the least-squares minimiser satisfies
  // L z = div(pbar, gbar): the Neumann 5-point Laplacian against the
  // backward difference of the half-pixel averages (zero outside the grid).
  const int w = 33;
  const int h = 26;
  const cv::Mat p = random_field(w, h, 14);
  const cv::Mat q = random_field(w, h, 15);
  const auto result = integrate_poisson(p, q);
  ASSERT_TRUE(result.has_value());
  const cv::Mat& z = *result;
  auto at = [&](const cv::Mat& m, int r, int c) { return static_cast<double>(m.at<float>(r, c)); };
  auto pbar = [&](int r, int c) {  // between (r, c) and (r, c+1)
    return c < 0 || c + 1 >= w ? 0.0 : 0.5 * (at(p, r, c) + at(p, r, c + 1));
  };
  auto gbar = [&](int r, int c) {  // between (r, c) and (r+1, c); g = -q
    return r < 0 || r + 1 >= h ? 0.0 : -0.5 * (at(q, r, c) + at(q, r + 1, c));
  };
  double worst = 0.0;
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c) {
      double laplacian = 0.0;
      if (c > 0) laplacian += at(z, r, c - 1) - at(z, r, c);
      if (c + 1 < w) laplacian += at(z, r, c + 1) - at(z, r, c);
      if (r > 0) laplacian += at(z, r - 1, c) - at(z, r, c);
      if (r + 1 < h) laplacian += at(z, r + 1, c) - at(z, r, c);
      const double divergence = pbar(r, c) - pbar(r, c - 1) + gbar(r, c) - gbar(r - 1, c);
      worst = std::max(worst, std::abs(laplacian - divergence));
    }
  }
  std::printf("  [measured] Poisson normal equations: max residual %.3g\n", worst);
  // Inputs are O(1); float z of magnitude ~1 differenced: measured 8e-7.
  EXPECT_LT(worst, 1e-5);
}

// ---------------------------------------------------------------------------
// Threads.

TEST(Integration, MaxSlopeKeepsAWildPixelFromTiltingTheSurface) {
  cv::Mat p(40, 60, CV_32F, cv::Scalar(0)), q(40, 60, CV_32F, cv::Scalar(0));
  p.at<float>(20, 30) = 1e6f;  // one pixel's gradient gone wild
  for (const auto method : {IntegrationMethod::frankot_chellappa, IntegrationMethod::poisson}) {
    const auto wild = integrate(method, p, q);
    const auto clamped = integrate(method, p, q, 10.0f);
    ASSERT_TRUE(wild && clamped);
    double wild_range = 0, clamped_range = 0, low = 0, high = 0;
    cv::minMaxLoc(*wild, &low, &high);
    wild_range = high - low;
    cv::minMaxLoc(*clamped, &low, &high);
    clamped_range = high - low;
    EXPECT_GT(wild_range, 1e4) << to_string(method);
    EXPECT_LT(clamped_range, 11.0) << to_string(method);  // at most one pixel's worth of the limit
  }
  EXPECT_FALSE(integrate(IntegrationMethod::poisson, p, q, 0.0f));
}

TEST(Integration, IsBitIdenticalForAnyThreadCount) {
  if (std::thread::hardware_concurrency() < 2)
    GTEST_SKIP() << "one hardware thread: nothing to compare";
  const ThreadCountGuard guard;
  // Wide enough for several row chunks and for FFTW to split its loops;
  // odd sizes so no split is even.
  const int w = 643;
  const int h = 479;
  cv::Mat p = random_field(w, h, 16, 0.2F);
  cv::Mat q = random_field(w, h, 17, 0.2F);
  for (const auto method : {IntegrationMethod::frankot_chellappa, IntegrationMethod::poisson}) {
    set_thread_count(1);
    const auto reference = integrate(method, p, q);
    ASSERT_TRUE(reference.has_value());
    for (const int threads : {2, 3}) {
      set_thread_count(threads);  // capped at the hardware threads
      ASSERT_GE(thread_count(), 2);
      const auto z = integrate(method, p, q);
      ASSERT_TRUE(z.has_value());
      EXPECT_EQ(cv::norm(*reference, *z, cv::NORM_INF), 0.0)
          << to_string(method) << " with " << threads << " threads";
    }
  }
}

// ---------------------------------------------------------------------------
// Real data: the vase gradients of Queau's normal_integration set, with the
// depth they came from.

TEST(Integration, RecoversTheVaseDepth) {
  const auto folder = test::real_dataset("vase");
  if (!folder) GTEST_SKIP() << "real dataset 'vase' not present";
  cv::Mat p = cv::imread((*folder / "p.tiff").string(), cv::IMREAD_UNCHANGED);
  cv::Mat q = cv::imread((*folder / "q.tiff").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat depth = cv::imread((*folder / "depth_gt.tiff").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat mask = cv::imread((*folder / "mask.png").string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(p.empty() || q.empty() || depth.empty() || mask.empty());
  ASSERT_EQ(p.type(), CV_32FC1);
  ASSERT_EQ(q.type(), CV_32FC1);
  ASSERT_EQ(depth.type(), CV_32FC1);
  ASSERT_EQ(p.size(), mask.size());
  // Outside the mask the files hold 0 (checked: all finite, 0 off the vase);
  // zero anything non-finite anyway, as a caller must.
  const cv::Mat outside = mask == 0;
  for (cv::Mat* m : {&p, &q}) {
    const cv::Mat non_finite = *m != *m;  // NaN
    m->setTo(0.0F, non_finite);
    m->setTo(0.0F, cv::abs(*m) > std::numeric_limits<float>::max());
    const cv::Mat off_vase = (*m != 0.0F) & outside;
    EXPECT_EQ(cv::countNonZero(off_vase), 0);
  }
  for (const auto method : {IntegrationMethod::frankot_chellappa, IntegrationMethod::poisson}) {
    const auto z = integrate(method, p, q);
    ASSERT_TRUE(z.has_value());
    const double rms = rms_error(*z, depth, mask);
    std::printf("  [measured] vase, %s: rms %.4g (depth range inside the mask 0.46..73.1)\n",
                std::string(to_string(method)).c_str(), rms);
    // Measured rms 2.116 (fc) and 2.112 (poisson), mostly along the
    // silhouette, where the files clamp |p|, |q| at 10 and drop to 0 outside.
    EXPECT_LT(rms, 2.5) << to_string(method);
  }
  // The files follow docs/design.md's axes (q = dz/dy, y up): read as dz/drow, q
  // would give a different surface far from the truth.
  const auto flipped = integrate_frankot_chellappa(p, -q);
  ASSERT_TRUE(flipped.has_value());
  const double flipped_rms = rms_error(*flipped, depth, mask);
  std::printf("  [measured] vase, fc with q negated: rms %.4g\n", flipped_rms);
  EXPECT_GT(flipped_rms, 5.0);
}

}  // namespace
}  // namespace psrig::processing

// ---------------------------------------------------------------------------
// Masked least squares.

namespace psrig::processing {
namespace {

cv::Mat disk_mask(int width, int height, double cx, double cy, double radius) {
  cv::Mat mask(height, width, CV_8U, cv::Scalar(0));
  cv::circle(mask, cv::Point(static_cast<int>(cx), static_cast<int>(cy)), static_cast<int>(radius),
             cv::Scalar(255), cv::FILLED);
  return mask;
}

// Gradients as a masked input arrives at FC: zero outside the mask.
std::pair<cv::Mat, cv::Mat> zero_outside(const Gradients& g, const cv::Mat& mask) {
  cv::Mat p = g.p.clone();
  cv::Mat q = g.q.clone();
  p.setTo(0.0F, mask == 0);
  q.setTo(0.0F, mask == 0);
  return {p, q};
}

TEST(IntegrationMasked, ParsesItsNames) {
  EXPECT_EQ(parse_integration_method("masked"), IntegrationMethod::masked);
  EXPECT_EQ(parse_integration_method("auto"), IntegrationMethod::automatic);
  EXPECT_EQ(to_string(IntegrationMethod::masked), "masked");
  EXPECT_EQ(to_string(IntegrationMethod::automatic), "auto");
}

TEST(IntegrationMasked, AnalyticSurfaceInADiskIsHundredsOfTimesBetterThanFc) {
  const int w = 160;
  const int h = 120;
  const Gradients g = analytic_surface(w, h);
  const cv::Mat mask = disk_mask(w, h, 80, 60, 50);
  const auto [p, q] = zero_outside(g, mask);
  const auto fc = integrate_frankot_chellappa(p, q);
  const auto poisson = integrate_poisson(p, q);
  MaskedIntegrationStats stats;
  const auto masked = integrate_masked(p, q, mask, {}, &stats);
  ASSERT_TRUE(fc && poisson && masked) << masked.error().describe();
  const double fc_rms = rms_error(*fc, g.z, mask);
  const double poisson_rms = rms_error(*poisson, g.z, mask);
  const double masked_rms = rms_error(*masked, g.z, mask);
  std::printf(
      "  [measured] analytic in a disk (r 50): fc rms %.4g, poisson rms %.4g, masked rms %.4g "
      "(%d iterations, residual %.2g): fc / masked = %.0f\n",
      fc_rms, poisson_rms, masked_rms, stats.iterations, stats.relative_residual,
      fc_rms / masked_rms);
  EXPECT_LT(100.0 * masked_rms, fc_rms);
  EXPECT_LT(100.0 * masked_rms, poisson_rms);
  EXPECT_LT(masked_rms, 1e-3);
  // NaN outside the disk, finite inside, zero mean inside.
  int nan_outside = 0;
  int finite_inside = 0;
  for (int r = 0; r < h; ++r)
    for (int c = 0; c < w; ++c) {
      const float v = masked->at<float>(r, c);
      if (mask.at<uchar>(r, c) == 0)
        nan_outside += std::isnan(v) ? 1 : 0;
      else
        finite_inside += std::isfinite(v) ? 1 : 0;
    }
  EXPECT_EQ(nan_outside, w * h - cv::countNonZero(mask));
  EXPECT_EQ(finite_inside, cv::countNonZero(mask));
  EXPECT_LT(std::abs(cv::mean(*masked, mask)[0]), 1e-4);
}

TEST(IntegrationMasked, OnTheWholeRectangleBeatsPoissonsTrapezoid) {
  // Every pixel inside: the same least squares as the Poisson solver, with
  // each edge's target integrated to fourth order instead of by the
  // trapezoid rule.
  const Gradients g = analytic_surface(160, 120);
  const auto poisson = integrate_poisson(g.p, g.q);
  MaskedIntegrationStats stats;
  const auto masked = integrate_masked(g.p, g.q, {}, {}, &stats);
  ASSERT_TRUE(poisson && masked);
  const double poisson_rms = rms_error(*poisson, g.z);
  const double masked_rms = rms_error(*masked, g.z);
  std::printf("  [measured] whole rectangle: poisson rms %.3g, masked rms %.3g (%d iterations)\n",
              poisson_rms, masked_rms, stats.iterations);
  EXPECT_LT(10.0 * masked_rms, poisson_rms);
  EXPECT_LT(std::abs(cv::mean(*masked)[0]), 1e-5);
}

TEST(IntegrationMasked, IsExactForAPlaneAndSolvesItsNormalEquations) {
  // A plane is integrated exactly by every rule; random fields leave the
  // relative residual the solver reports below its tolerance.
  cv::Mat p(50, 70, CV_32F, cv::Scalar(0.25));
  cv::Mat q(50, 70, CV_32F, cv::Scalar(-0.4));
  const cv::Mat mask = disk_mask(70, 50, 30, 25, 22);
  const auto z = integrate_masked(p, q, mask);
  ASSERT_TRUE(z.has_value());
  EXPECT_NEAR(z->at<float>(25, 40) - z->at<float>(25, 20), 5.0, 1e-4);
  EXPECT_NEAR(z->at<float>(15, 30) - z->at<float>(35, 30), -8.0, 1e-4);  // y up, q < 0
  MaskedIntegrationStats stats;
  MaskedIntegrationOptions options;
  options.tolerance = 1e-5;
  ASSERT_TRUE(
      integrate_masked(random_field(70, 50, 25), random_field(70, 50, 26), mask, options, &stats));
  std::printf("  [measured] random field in a disk: %d iterations, residual %.2g\n",
              stats.iterations, stats.relative_residual);
  EXPECT_LT(stats.relative_residual, 1e-5);
  EXPECT_LT(stats.iterations, 20);
}

TEST(IntegrationMasked, NonFiniteGradientsAreHolesAndPiecesHaveZeroMean) {
  // Two separate squares with different planes, and a NaN hole in one.
  cv::Mat p(40, 60, CV_32F, cv::Scalar(0));
  cv::Mat q(40, 60, CV_32F, cv::Scalar(0));
  cv::Mat mask(40, 60, CV_8U, cv::Scalar(0));
  mask(cv::Rect(2, 2, 20, 30)).setTo(255);
  mask(cv::Rect(30, 5, 25, 25)).setTo(255);
  p(cv::Rect(2, 2, 20, 30)).setTo(0.5F);
  q(cv::Rect(30, 5, 25, 25)).setTo(-0.3F);
  p.at<float>(10, 10) = std::numeric_limits<float>::quiet_NaN();
  const auto z = integrate_masked(p, q, mask);
  ASSERT_TRUE(z.has_value());
  EXPECT_TRUE(std::isnan(z->at<float>(10, 10)));
  EXPECT_TRUE(std::isnan(z->at<float>(0, 0)));
  cv::Mat first = mask.clone();
  first(cv::Rect(30, 0, 30, 40)).setTo(0);
  first.at<uchar>(10, 10) = 0;
  cv::Mat second = mask.clone();
  second(cv::Rect(0, 0, 30, 40)).setTo(0);
  EXPECT_LT(std::abs(cv::mean(*z, first)[0]), 1e-5);
  EXPECT_LT(std::abs(cv::mean(*z, second)[0]), 1e-5);
  EXPECT_NEAR(z->at<float>(20, 15) - z->at<float>(20, 5), 5.0, 1e-4);
  EXPECT_NEAR(z->at<float>(10, 40) - z->at<float>(20, 40), -3.0, 1e-4);  // y up
  // `automatic` sees the mask, or the NaN, and chooses the masked solver.
  EXPECT_TRUE(needs_masked_integration(p, q));
  EXPECT_TRUE(needs_masked_integration(cv::Mat(4, 4, CV_32F, cv::Scalar(0)),
                                       cv::Mat(4, 4, CV_32F, cv::Scalar(0)),
                                       mask(cv::Rect(0, 0, 4, 4))));
  EXPECT_FALSE(needs_masked_integration(cv::Mat(4, 4, CV_32F, cv::Scalar(0)),
                                        cv::Mat(4, 4, CV_32F, cv::Scalar(0))));
  const auto automatic = integrate(IntegrationMethod::automatic, p, q, mask);
  ASSERT_TRUE(automatic.has_value());
  EXPECT_TRUE(std::isnan(automatic->at<float>(0, 0)));
}

TEST(IntegrationMasked, HandlesDegenerateSizes) {
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(1, 7), cv::Size(7, 1), cv::Size(2, 2),
                              cv::Size(5, 3), cv::Size(9, 6)}) {
    const cv::Mat p = random_field(size.width, size.height, 27);
    const cv::Mat q = random_field(size.width, size.height, 28);
    const auto z = integrate_masked(p, q, {});
    ASSERT_TRUE(z.has_value()) << z.error().describe();
    EXPECT_EQ(z->size(), size);
    EXPECT_TRUE(cv::checkRange(*z)) << size;
    EXPECT_LT(std::abs(cv::mean(*z)[0]), 1e-5) << size;
  }
  // One row: the least-squares fit of a constant slope is exact.
  const auto row = integrate_masked(cv::Mat(1, 9, CV_32F, cv::Scalar(0.5)),
                                    cv::Mat(1, 9, CV_32F, cv::Scalar(7.0)), {});
  ASSERT_TRUE(row.has_value());
  for (int col = 0; col < 9; ++col)
    EXPECT_NEAR(row->at<float>(0, col), 0.5 * (col - 4), 1e-5);
}

TEST(IntegrationMasked, RejectsBadInputs) {
  const cv::Mat good(8, 10, CV_32F, cv::Scalar(0.1));
  EXPECT_FALSE(integrate_masked(good, cv::Mat(8, 11, CV_32F), {}));
  EXPECT_FALSE(integrate_masked(good, good, cv::Mat(8, 11, CV_8U)));
  EXPECT_FALSE(integrate_masked(good, good, cv::Mat(8, 10, CV_32F)));
  EXPECT_FALSE(integrate_masked(cv::Mat(), good, {}));
  const auto r = integrate_masked(good, good, cv::Mat(8, 10, CV_16U));
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().kind, ErrorKind::bad_input);
}

TEST(IntegrationMasked, IsBitIdenticalForAnyThreadCount) {
  if (std::thread::hardware_concurrency() < 2)
    GTEST_SKIP() << "one hardware thread: nothing to compare";
  const ThreadCountGuard guard;
  const int w = 301;
  const int h = 211;
  const cv::Mat p = random_field(w, h, 23, 0.2F);
  const cv::Mat q = random_field(w, h, 24, 0.2F);
  const cv::Mat mask = disk_mask(w, h, 150, 100, 90);
  set_thread_count(1);
  const auto reference = integrate_masked(p, q, mask);
  ASSERT_TRUE(reference.has_value());
  set_thread_count(2);
  const auto z = integrate_masked(p, q, mask);
  ASSERT_TRUE(z.has_value());
  EXPECT_EQ(cv::norm(*reference, *z, cv::NORM_INF, mask), 0.0);
}

// Handed over (moved in), the gradients give the same heights, and the
// caller's headers are left empty: the solver let them go.
TEST(IntegrationMasked, HandedOverGradientsGiveTheSameHeights) {
  const cv::Mat p = random_field(123, 77, 31, 0.2F);
  const cv::Mat q = random_field(123, 77, 32, 0.2F);
  const cv::Mat mask = disk_mask(123, 77, 60, 40, 35);
  MaskedIntegrationStats kept_stats, handed_stats;
  const auto kept = integrate_masked(p, q, mask, {}, &kept_stats);
  cv::Mat p_own = p.clone();
  cv::Mat q_own = q.clone();
  const auto handed = integrate_masked(std::move(p_own), std::move(q_own), mask, {}, &handed_stats);
  ASSERT_TRUE(kept && handed);
  EXPECT_TRUE(p_own.empty() && q_own.empty());
  EXPECT_EQ(cv::norm(*kept, *handed, cv::NORM_INF, mask), 0.0);
  EXPECT_EQ(kept_stats.iterations, handed_stats.iterations);
  EXPECT_FALSE(integrate_masked(cv::Mat(), cv::Mat(), cv::Mat()));  // still checked
}

TEST(IntegrationMasked, RecoversTheVaseDepth) {
  const auto folder = test::real_dataset("vase");
  if (!folder) GTEST_SKIP() << "real dataset 'vase' not present";
  const cv::Mat p = cv::imread((*folder / "p.tiff").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat q = cv::imread((*folder / "q.tiff").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat depth = cv::imread((*folder / "depth_gt.tiff").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat mask = cv::imread((*folder / "mask.png").string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(p.empty() || q.empty() || depth.empty() || mask.empty());
  MaskedIntegrationStats stats;
  const auto z = integrate_masked(p, q, mask, {}, &stats);
  ASSERT_TRUE(z.has_value());
  const auto fc = integrate_frankot_chellappa(p, q);
  ASSERT_TRUE(fc.has_value());
  const double rms = rms_error(*z, depth, mask);
  const double fc_rms = rms_error(*fc, depth, mask);
  std::printf("  [measured] vase, masked: rms %.4g (%d iterations, residual %.2g); fc rms %.4g\n",
              rms, stats.iterations, stats.relative_residual, fc_rms);
  EXPECT_LT(rms, 0.1);
}

}  // namespace
}  // namespace psrig::processing
