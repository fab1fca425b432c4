#include "psrig/calibration/colour.h"

#include <algorithm>
#include <cmath>
#include <lcms2.h>
#include <memory>
#include <optional>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <opencv2/mcc.hpp>

#include "psrig/formats/image_io.h"
#include "psrig/processing/linearise.h"

namespace psrig::calibration {

namespace {

// lcms2 transforms between L*a*b* (D50, the ICC connection space) and
// linear sRGB: a matrix-shaper profile with sRGB's primaries, D65 white
// and a gamma-1 tone curve. Made once; without a cache they may be used
// from several threads at once.
struct LcmsTransforms {
  cmsHTRANSFORM lab_to_rgb = nullptr;
  cmsHTRANSFORM rgb_to_lab = nullptr;

  LcmsTransforms() {
    cmsCIExyY d65{0.3127, 0.3290, 1.0};
    cmsCIExyYTRIPLE primaries{{0.64, 0.33, 1.0}, {0.30, 0.60, 1.0}, {0.15, 0.06, 1.0}};
    cmsToneCurve* linear = cmsBuildGamma(nullptr, 1.0);
    cmsToneCurve* curves[3] = {linear, linear, linear};
    cmsHPROFILE rgb = cmsCreateRGBProfile(&d65, &primaries, curves);
    cmsHPROFILE lab = cmsCreateLab4Profile(nullptr);  // D50
    const cmsUInt32Number flags = cmsFLAGS_NOCACHE | cmsFLAGS_NOOPTIMIZE;
    lab_to_rgb = cmsCreateTransform(lab, TYPE_Lab_DBL, rgb, TYPE_RGB_DBL,
                                    INTENT_RELATIVE_COLORIMETRIC, flags);
    rgb_to_lab = cmsCreateTransform(rgb, TYPE_RGB_DBL, lab, TYPE_Lab_DBL,
                                    INTENT_RELATIVE_COLORIMETRIC, flags);
    cmsCloseProfile(rgb);
    cmsCloseProfile(lab);
    cmsFreeToneCurve(linear);
  }
  ~LcmsTransforms() {
    if (lab_to_rgb) cmsDeleteTransform(lab_to_rgb);
    if (rgb_to_lab) cmsDeleteTransform(rgb_to_lab);
  }
  LcmsTransforms(const LcmsTransforms&) = delete;
  LcmsTransforms& operator=(const LcmsTransforms&) = delete;
};

const LcmsTransforms& transforms() {
  static const LcmsTransforms t;
  return t;
}

double luminance(const cv::Vec3d& rgb) {  // linear sRGB's Y
  return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
}

// The model chart of OpenCV's mcc (checker_model.cpp, "Standard"): the
// box is 16.75 x 11.25 units; patches 2.5 units with 0.25 between them,
// the first one's corner at (0.25, 0.25); row-major from dark skin.
constexpr double kModelPatch = 2.5;
constexpr double kModelPitch = 2.75;
constexpr double kModelMargin = 0.25;
const std::vector<cv::Point2f> kModelBox = {{0, 0}, {16.75f, 0}, {16.75f, 11.25f}, {0, 11.25f}};

cv::Point2d model_centre(int patch) {
  return {kModelMargin + kModelPatch / 2 + kModelPitch * (patch % kChartColumns),
          kModelMargin + kModelPatch / 2 + kModelPitch * (patch / kChartColumns)};
}

// 8-bit sRGB-encoded BGR for mcc (its colour matching assumes sRGB): the
// linear image over its 99.5th percentile.
cv::Mat to_srgb8(const cv::Mat& linear_bgr) {
  cv::Mat grey;
  cv::transform(linear_bgr, grey, cv::Matx13f(1.f / 3, 1.f / 3, 1.f / 3));
  std::vector<float> values(grey.begin<float>(), grey.end<float>());
  const auto at = values.begin() + static_cast<std::ptrdiff_t>(values.size() * 995 / 1000);
  std::nth_element(values.begin(), at, values.end());
  const double top = std::max(static_cast<double>(*at), 1e-9);
  cv::Mat scaled = linear_bgr / top;
  cv::Mat bytes(scaled.size(), CV_8UC3);
  // The sRGB curve through a table of 4096 steps.
  std::vector<unsigned char> curve(4097);
  for (int i = 0; i <= 4096; ++i) {
    const double v = i / 4096.0;
    const double e = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1 / 2.4) - 0.055;
    curve[static_cast<std::size_t>(i)] = cv::saturate_cast<unsigned char>(255 * e);
  }
  scaled.forEach<cv::Vec3f>([&](const cv::Vec3f& v, const int* p) {
    auto& out = bytes.at<cv::Vec3b>(p[0], p[1]);
    for (int c = 0; c < 3; ++c)
      out[c] = curve[static_cast<std::size_t>(std::clamp(v[c], 0.f, 1.f) * 4096.f + 0.5f)];
  });
  return bytes;
}

// The robust mean of one patch: the pixels whose model coordinates lie in
// the patch's middle half, per channel within 3 MADs of the median.
void read_patch(const cv::Mat& linear_bgr, const cv::Mat& saturated, const cv::Matx33d& to_image,
                int patch, ChartReading& reading) {
  const cv::Point2d c = model_centre(patch);
  const double half = kModelPatch / 4;
  std::vector<cv::Point2f> square = {
      {static_cast<float>(c.x - half), static_cast<float>(c.y - half)},
      {static_cast<float>(c.x + half), static_cast<float>(c.y - half)},
      {static_cast<float>(c.x + half), static_cast<float>(c.y + half)},
      {static_cast<float>(c.x - half), static_cast<float>(c.y + half)}};
  std::vector<cv::Point2f> corners;
  cv::perspectiveTransform(square, corners, cv::Matx33f(to_image));
  std::vector<cv::Point2f> centre_in;
  cv::perspectiveTransform(std::vector<cv::Point2f>{cv::Point2f(c)}, centre_in,
                           cv::Matx33f(to_image));
  reading.centre[static_cast<std::size_t>(patch)] = centre_in.front();
  std::vector<cv::Point> polygon;
  for (const auto& p : corners)
    polygon.emplace_back(cvRound(p.x), cvRound(p.y));
  cv::Mat inside = cv::Mat::zeros(linear_bgr.size(), CV_8U);
  cv::fillConvexPoly(inside, polygon, 255);
  std::array<std::vector<float>, 3> channel;
  int saturated_count = 0;
  for (int r = 0; r < inside.rows; ++r)
    for (int col = 0; col < inside.cols; ++col) {
      if (!inside.at<unsigned char>(r, col)) continue;
      const auto& v = linear_bgr.at<cv::Vec3f>(r, col);
      for (int k = 0; k < 3; ++k)
        channel[static_cast<std::size_t>(k)].push_back(v[k]);
      if (!saturated.empty() && saturated.at<unsigned char>(r, col)) ++saturated_count;
    }
  const std::size_t n = channel[0].size();
  reading.pixels[static_cast<std::size_t>(patch)] = static_cast<int>(n);
  reading.saturated[static_cast<std::size_t>(patch)] =
      n ? static_cast<double>(saturated_count) / static_cast<double>(n) : 0.0;
  if (n == 0) return;
  const auto median = [](std::vector<float> v) {
    const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    return static_cast<double>(*mid);
  };
  std::array<double, 3> med{}, mad{};
  for (std::size_t k = 0; k < 3; ++k) {
    med[k] = median(channel[k]);
    std::vector<float> deviation(n);
    for (std::size_t i = 0; i < n; ++i)
      deviation[i] = std::abs(channel[k][i] - static_cast<float>(med[k]));
    mad[k] = 1.4826 * median(deviation);
  }
  cv::Vec3d sum(0, 0, 0);
  int kept = 0;
  for (std::size_t i = 0; i < n; ++i) {
    bool keep = true;
    for (std::size_t k = 0; k < 3; ++k)
      keep = keep && std::abs(channel[k][i] - med[k]) <= 3 * mad[k] + 1e-12;
    if (!keep) continue;
    for (std::size_t k = 0; k < 3; ++k)
      sum[2 - static_cast<int>(k)] += channel[k][i];  // BGR → RGB
    ++kept;
  }
  reading.rgb[static_cast<std::size_t>(patch)] =
      kept ? sum / kept : cv::Vec3d(med[2], med[1], med[0]);
}

}  // namespace

const std::array<ChartPatch, kChartPatches>& colorchecker_classic() {
  // X-Rite, "New color specifications for ColorChecker SG and Classic
  // charts" (2015), the values for charts made after November 2014,
  // L*a*b* D50 2°:
  // https://www.xrite.com/service-support/new_color_specifications_for_colorchecker_sg_and_classic_charts
  // (OpenCV's mcc ships the older BabelColor 2005 averages for its own
  // detection; psrig keeps this one table.)
  static const std::array<ChartPatch, kChartPatches> patches = {{
      {"dark skin", {37.54, 14.37, 14.92}},     {"light skin", {64.66, 19.27, 17.50}},
      {"blue sky", {49.32, -3.82, -22.54}},     {"foliage", {43.46, -12.74, 22.72}},
      {"blue flower", {54.94, 9.61, -24.79}},   {"bluish green", {70.48, -32.26, -0.37}},
      {"orange", {62.73, 35.83, 56.50}},        {"purplish blue", {39.43, 10.75, -45.17}},
      {"moderate red", {50.57, 48.64, 16.67}},  {"purple", {30.10, 22.54, -20.87}},
      {"yellow green", {71.77, -24.13, 58.19}}, {"orange yellow", {71.51, 18.24, 67.37}},
      {"blue", {28.37, 15.42, -49.80}},         {"green", {54.38, -39.72, 32.27}},
      {"red", {42.43, 51.05, 28.62}},           {"yellow", {81.80, 2.67, 80.41}},
      {"magenta", {50.63, 51.28, -14.12}},      {"cyan", {49.57, -29.71, -28.32}},
      {"white 9.5", {95.19, -1.03, 2.93}},      {"neutral 8", {81.29, -0.57, 0.44}},
      {"neutral 6.5", {66.89, -0.75, -0.06}},   {"neutral 5", {50.76, -0.13, 0.14}},
      {"neutral 3.5", {35.63, -0.46, -0.48}},   {"black 2", {20.64, 0.07, -0.46}},
  }};
  return patches;
}

cv::Vec3d lab_d50_to_linear_srgb(const cv::Vec3d& lab) {
  double in[3] = {lab[0], lab[1], lab[2]}, out[3] = {0, 0, 0};
  cmsDoTransform(transforms().lab_to_rgb, in, out, 1);
  return {out[0], out[1], out[2]};
}

cv::Vec3d linear_srgb_to_lab_d50(const cv::Vec3d& rgb) {
  double in[3] = {rgb[0], rgb[1], rgb[2]}, out[3] = {0, 0, 0};
  cmsDoTransform(transforms().rgb_to_lab, in, out, 1);
  return {out[0], out[1], out[2]};
}

double delta_e2000(const cv::Vec3d& lab1, const cv::Vec3d& lab2) {
  const cmsCIELab a{lab1[0], lab1[1], lab1[2]}, b{lab2[0], lab2[1], lab2[2]};
  return cmsCIE2000DeltaE(&a, &b, 1.0, 1.0, 1.0);
}

Result<ChartReading> read_colour_chart(const cv::Mat& linear_bgr, const cv::Mat& saturated,
                                       const std::filesystem::path& source) {
  const auto not_found = [&](const std::string& why) {
    return std::unexpected(bad_input(
        source, "",
        "shows no ColorChecker Classic (" + why +
            "): is the chart fully in view, lit, not saturated? Lay the 24-patch chart flat "
            "under the camera, its black frame all inside the image, and capture again"));
  };
  if (linear_bgr.empty() || linear_bgr.type() != CV_32FC3)
    return not_found("the image is not a colour image");
  const cv::Mat bytes = to_srgb8(linear_bgr);
  auto detector = cv::mcc::CCheckerDetector::create();
  // mcc scales images whose short side is below minImageSize (1000) up
  // first: tried at the image's own size, then as mcc would.
  auto params = cv::mcc::DetectorParameters::create();
  params->minImageSize = std::min(bytes.cols, bytes.rows);
  if (!detector->process(bytes, cv::mcc::MCC24, 1, false, params) &&
      !detector->process(bytes, cv::mcc::MCC24, 1, false))
    return not_found("no 4 x 6 patch grid found");
  const auto checker = detector->getBestColorChecker();
  if (!checker) return not_found("no 4 x 6 patch grid found");
  const std::vector<cv::Point2f> box = checker->getBox();
  if (box.size() != 4) return not_found("the chart's outline was not found");

  // mcc orders the box by its own colour matching; a reading through the
  // box turned half round is tried too and the neutral row decides: it
  // must run from white to black, its luminance falling patch by patch.
  std::optional<ChartReading> best;
  double best_score = -1;
  for (int turn : {0, 2}) {
    std::vector<cv::Point2f> turned(4);
    for (int i = 0; i < 4; ++i)
      turned[static_cast<std::size_t>(i)] = box[static_cast<std::size_t>((i + turn) % 4)];
    const cv::Matx33d to_image(cv::getPerspectiveTransform(kModelBox, turned));
    ChartReading reading;
    for (int i = 0; i < 4; ++i)
      reading.corners[static_cast<std::size_t>(i)] = turned[static_cast<std::size_t>(i)];
    bool inside = true;
    for (int p = 0; p < kChartPatches; ++p) {
      read_patch(linear_bgr, saturated, to_image, p, reading);
      inside = inside && reading.pixels[static_cast<std::size_t>(p)] >= 4;
    }
    if (!inside) continue;
    double score = 0;
    for (int p = kFirstNeutralPatch; p + 1 < kFirstNeutralPatch + kNeutralPatches; ++p) {
      const double here = cv::sum(reading.rgb[static_cast<std::size_t>(p)])[0];
      const double next = cv::sum(reading.rgb[static_cast<std::size_t>(p + 1)])[0];
      if (here > next) score += 1;
    }
    if (score > best_score) {
      best_score = score;
      best = reading;
    }
  }
  if (!best) return not_found("the chart runs off the image");
  if (best_score < kNeutralPatches - 1)
    return not_found("its bottom row does not run from white to black");
  return *best;
}

ColourCorrection fit_colour_correction(const std::array<cv::Vec3d, kChartPatches>& camera_rgb) {
  const auto& chart = colorchecker_classic();
  std::array<cv::Vec3d, kChartPatches> target;
  for (int p = 0; p < kChartPatches; ++p)
    target[static_cast<std::size_t>(p)] =
        lab_d50_to_linear_srgb(chart[static_cast<std::size_t>(p)].lab_d50);

  cv::Vec3d neutral_camera(0, 0, 0), neutral_target(0, 0, 0);
  for (int p = kFirstNeutralPatch; p < kFirstNeutralPatch + kNeutralPatches; ++p) {
    neutral_camera += camera_rgb[static_cast<std::size_t>(p)];
    neutral_target += target[static_cast<std::size_t>(p)];
  }

  // Per output channel r: minimise sum_i w_i (m_r . c_i - t_ir)^2 subject
  // to m_r . n_c = n_tr: the KKT system [2 C^T W C, n_c; n_c^T, 0].
  const auto solve = [&](const std::array<double, kChartPatches>& weight) {
    cv::Matx33d m;
    cv::Matx33d normal = cv::Matx33d::zeros();
    std::array<cv::Vec3d, 3> right{};
    for (int p = 0; p < kChartPatches; ++p) {
      const auto i = static_cast<std::size_t>(p);
      const auto& c = camera_rgb[i];
      normal += weight[i] * (c * c.t());
      for (int r = 0; r < 3; ++r)
        right[static_cast<std::size_t>(r)] += weight[i] * target[i][r] * c;
    }
    for (int r = 0; r < 3; ++r) {
      cv::Matx44d kkt = cv::Matx44d::zeros();
      cv::Vec4d rhs;
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j)
          kkt(i, j) = normal(i, j);
        kkt(i, 3) = neutral_camera[i];
        kkt(3, i) = neutral_camera[i];
        rhs[i] = right[static_cast<std::size_t>(r)][i];
      }
      rhs[3] = neutral_target[r];
      cv::Vec4d solution;
      cv::solve(kkt, rhs, solution, cv::DECOMP_SVD);
      for (int j = 0; j < 3; ++j)
        m(r, j) = solution[j];
    }
    return m;
  };
  std::array<double, kChartPatches> base{};
  for (int p = 0; p < kChartPatches; ++p)
    base[static_cast<std::size_t>(p)] =
        1.0 / (luminance(target[static_cast<std::size_t>(p)]) + 0.05);
  cv::Matx33d full = solve(base);
  // A patch the matrix cannot reach (a colour the camera clips, like the
  // cyan outside an sRGB-like sensor's gamut, a glint, dirt) is weighed
  // down where its ΔE is over 3 times the median, twice (iteratively
  // reweighted least squares), so it does not pull the others off.
  for (int pass = 0; pass < 2; ++pass) {
    std::array<double, kChartPatches> error{};
    for (int p = 0; p < kChartPatches; ++p) {
      const auto i = static_cast<std::size_t>(p);
      error[i] = delta_e2000(chart[i].lab_d50, linear_srgb_to_lab_d50(full * camera_rgb[i]));
    }
    std::array<double, kChartPatches> sorted = error;
    std::nth_element(sorted.begin(), sorted.begin() + kChartPatches / 2, sorted.end());
    const double limit = 3 * std::max(sorted[kChartPatches / 2], 0.1);
    std::array<double, kChartPatches> weight = base;
    for (std::size_t i = 0; i < weight.size(); ++i)
      if (error[i] > limit) weight[i] *= (limit / error[i]) * (limit / error[i]);
    full = solve(weight);
  }

  ColourCorrection result;
  // The chart's exposure: reference neutral level over the camera's.
  const double camera_level = (neutral_camera[0] + neutral_camera[1] + neutral_camera[2]) / 3;
  const double target_level = (neutral_target[0] + neutral_target[1] + neutral_target[2]) / 3;
  result.exposure = camera_level > 0 ? target_level / camera_level : 1.0;
  result.matrix = full * (1.0 / result.exposure);
  for (int p = 0; p < kChartPatches; ++p) {
    const auto i = static_cast<std::size_t>(p);
    const cv::Vec3d before = camera_rgb[i] * result.exposure;
    const cv::Vec3d after = full * camera_rgb[i];
    result.lab_before[i] = linear_srgb_to_lab_d50(before);
    result.lab_after[i] = linear_srgb_to_lab_d50(after);
    result.delta_e_before[i] = delta_e2000(chart[i].lab_d50, result.lab_before[i]);
    result.delta_e_after[i] = delta_e2000(chart[i].lab_d50, result.lab_after[i]);
    result.mean_before += result.delta_e_before[i] / kChartPatches;
    result.mean_after += result.delta_e_after[i] / kChartPatches;
    result.max_before = std::max(result.max_before, result.delta_e_before[i]);
    result.max_after = std::max(result.max_after, result.delta_e_after[i]);
  }
  return result;
}

Result<LinearColourImage> read_linear_colour(const std::filesystem::path& file,
                                             formats::Encoding encoding) {
  auto stored = formats::read_image(file, "--image");
  if (!stored) return std::unexpected(stored.error());
  const cv::Mat& image = *stored;
  if (image.channels() < 3)
    return std::unexpected(bad_input(file, "--image",
                                     "is a grey image; the colour calibration needs the "
                                     "camera's colour frame of the chart (RGB)"));
  if (image.depth() != CV_8U && image.depth() != CV_16U && image.depth() != CV_32F)
    return std::unexpected(bad_input(
        file, "--image",
        "has an unsupported pixel type; give an 8- or 16-bit PNG or a 32-bit float TIFF/EXR"));
  cv::Mat bgr = image;
  if (bgr.channels() == 4) cv::cvtColor(image, bgr, cv::COLOR_BGRA2BGR);
  const double full = formats::full_scale(bgr.depth());
  LinearColourImage out;
  cv::Mat planes[3];
  cv::split(bgr, planes);
  // At or near full scale (a 12-bit sensor's full scale in 16 bits is
  // 65520), as for the rig's own captures.
  const double limit = 0.98 * (bgr.depth() == CV_32F ? 1.0 : full);
  out.saturated = (planes[0] >= limit) | (planes[1] >= limit) | (planes[2] >= limit);
  const processing::CodeLineariser lineariser(encoding, 0, full, bgr.depth());
  cv::Mat continuous = bgr.isContinuous() ? bgr : bgr.clone();
  out.bgr = cv::Mat(continuous.size(), CV_32FC3);
  lineariser.convert(continuous.data, static_cast<int>(continuous.total()) * 3,
                     out.bgr.ptr<float>());
  return out;
}

}  // namespace psrig::calibration
