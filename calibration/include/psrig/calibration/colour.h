#pragma once
// Colour calibration from an X-Rite/Calibrite ColorChecker Classic: the
// chart found by OpenCV's mcc module, each patch's linear camera RGB, a
// 3x3 matrix from camera RGB to linear sRGB (D65) fitted in linear light,
// and CIEDE2000 per patch before and after (lcms2).
//
// Colours are RGB in this interface (index 0 red); images are OpenCV's BGR.

#include <array>
#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/formats/scan.h"

namespace psrig::calibration {

inline constexpr int kChartPatches = 24;
inline constexpr int kChartColumns = 6;
inline constexpr int kChartRows = 4;
// Patch indices (row-major, dark skin first) of the bottom row's neutrals.
inline constexpr int kFirstNeutralPatch = 18;  // white 9.5
inline constexpr int kNeutralPatches = 6;      // white … black 2

struct ChartPatch {
  const char* name;
  cv::Vec3d lab_d50;  // CIE L*a*b*, D50, 2° observer
};

// The ColorChecker Classic's 24 patches as X-Rite publishes them for
// charts made after November 2014: row-major, dark skin first.
[[nodiscard]] const std::array<ChartPatch, kChartPatches>& colorchecker_classic();

// Linear sRGB (D65 white, 1 = the perfect diffuser) of L*a*b* (D50), and
// back: lcms2's Lab profile (D50) and a linear-tone sRGB matrix-shaper
// profile, relative colorimetric, so D65 white meets D50 white through
// the Bradford adaptation lcms builds into the profile. Unbounded: colours
// outside sRGB's gamut (the cyan patch) keep their negative components.
[[nodiscard]] cv::Vec3d lab_d50_to_linear_srgb(const cv::Vec3d& lab);
[[nodiscard]] cv::Vec3d linear_srgb_to_lab_d50(const cv::Vec3d& rgb);

// CIEDE2000 (kL = kC = kH = 1), lcms2's cmsCIE2000DeltaE.
[[nodiscard]] double delta_e2000(const cv::Vec3d& lab1, const cv::Vec3d& lab2);

// The chart as found in an image.
struct ChartReading {
  std::array<cv::Vec3d, kChartPatches> rgb;       // linear camera RGB, robust mean per patch
  std::array<cv::Point2d, kChartPatches> centre;  // px
  std::array<int, kChartPatches> pixels{};        // sampled per patch
  std::array<double, kChartPatches> saturated{};  // fraction of each patch at full scale
  std::array<cv::Point2f, 4> corners;             // the chart's patch field (mcc's box), px
};

// Finds the chart in a linear BGR image (CV_32FC3, any scale) and reads
// its patches: the middle half of each patch (a quarter of its area, away
// from its edges and the black frame), per channel the mean of the pixels
// within 3 MADs of the median. `saturated` (CV_8U, nonzero where a pixel
// reached full scale in any frame; may be empty) counts per patch.
// bad_input naming `source` when no chart is found.
[[nodiscard]] Result<ChartReading> read_colour_chart(const cv::Mat& linear_bgr,
                                                     const cv::Mat& saturated,
                                                     const std::filesystem::path& source);

// A chart reading's colour correction.
//
// The fit: weighted least squares in linear light, each patch weighted by
// 1 / (its reference luminance + 0.05) so dark patches count in
// proportion to how visible their errors are, under the constraint that
// the sum of the six neutral patches maps exactly onto their reference
// (grey stays grey). The matrix absorbs the chart's exposure; `matrix`
// is normalised so that the neutral patches keep the camera's mean level
// (mean of the three channels) after correction: it changes colour, not
// brightness, and applies to any exposure. `exposure` scales corrected
// camera RGB to the chart's reference for the ΔE tables.
struct ColourCorrection {
  cv::Matx33d matrix;  // camera RGB → linear sRGB D65, exposure-free
  double exposure = 1;
  // Per patch, with the exposure applied: camera RGB taken as sRGB
  // (before) and corrected (after), against the reference.
  std::array<double, kChartPatches> delta_e_before{};
  std::array<double, kChartPatches> delta_e_after{};
  std::array<cv::Vec3d, kChartPatches> lab_before;
  std::array<cv::Vec3d, kChartPatches> lab_after;
  double mean_before = 0, max_before = 0, mean_after = 0, max_after = 0;
};

[[nodiscard]] ColourCorrection fit_colour_correction(
    const std::array<cv::Vec3d, kChartPatches>& camera_rgb);

// (processing's colour_correction.h applies the matrix to an image.)

// An image of the chart already taken: linear BGR (CV_32FC3, 0..1 of full
// scale after decoding `encoding`) and where it reached full scale in any
// channel (CV_8U). bad_input naming the file when it is not a colour image
// (the colour calibration needs the camera's colour frames).
struct LinearColourImage {
  cv::Mat bgr;
  cv::Mat saturated;
};
[[nodiscard]] Result<LinearColourImage> read_linear_colour(const std::filesystem::path& file,
                                                           formats::Encoding encoding);

}  // namespace psrig::calibration
