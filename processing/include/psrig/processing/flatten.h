#pragma once
// Removing the low-frequency bend from a height map. Errors in the light
// model (a light's direction or intensity a little off, lights nearer than
// assumed) bias every gradient a little the same way, and integration turns
// that into a bowl or a saddle across the whole swatch. A flat swatch must
// come out flat: the bend is estimated and subtracted, the relief kept.
//
// Method: a least-squares quadratic surface over the valid pixels (the bulk
// of the bend, with no edge effects), then the Gaussian low-pass of what
// remains (ISO 16610-21's weighting: sigma = cutoff sqrt(ln 2 / 2) / pi,
// 50 % transmission at the cut-off wavelength), taken by normalised
// convolution so that holes and borders weigh nothing. The bend is their
// sum. Relief at wavelengths well below the cut-off passes almost whole
// (transmission 1 - exp(-pi (0.4697 cutoff / wavelength)^2): at a fifth of
// the cut-off 1 - 3e-8, at a third 99.8 %, at half 93.7 %), while a bend
// across the swatch is taken out whole by the quadratic, its remainder by
// the low-pass.

#include <opencv2/core.hpp>

#include "psrig/base/error.h"

namespace psrig::processing {

// Cut-off wavelength used for swatch scans unless told otherwise.
inline constexpr double kDefaultFlattenCutoffMm = 10.0;

struct BendRemoved {
  cv::Mat bend;               // CV_32F, what was subtracted; NaN where the height is
                              // (empty unless keep_bend)
  double peak_to_valley = 0;  // max - min of the bend over the valid pixels
  double rms = 0;             // RMS of the bend about its mean there
};

// Subtracts the bend from `height` (CV_32FC1; non-finite = no data, left
// as is) in place. `cutoff` is in pixels (the caller converts millimetres
// with the scan's pixel size) and must be positive. Without keep_bend the
// bend itself is not returned, only its size (the pipeline's case: a plane
// less).
[[nodiscard]] Result<BendRemoved> remove_bend(cv::Mat& height, double cutoff_px,
                                              bool keep_bend = true);

}  // namespace psrig::processing
