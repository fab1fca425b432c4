#pragma once
// Specks in a height map: the few pixels inside a swatch the solve could
// not vouch for (a dark fleck, a grazing fibre) are left out of the masked
// integration like real holes, but a swatch is not lace: a NaN speck would
// become a pit in the preview and a tear in an exported material. Specks
// (NaN components up to a small area) are filled by a harmonic (Laplace)
// interpolation of the heights around them; larger NaN regions are holes
// and stay NaN.

#include <opencv2/core.hpp>

namespace psrig::processing {

// Fills, in `height` (CV_32FC1), each 4-connected component of NaN pixels
// that lies where `fillable` is non-zero, has at most `max_area` pixels and
// touches no NaN pixel outside `fillable`; returns how many were filled.
int fill_specks(cv::Mat& height, const cv::Mat& fillable, int max_area);

}  // namespace psrig::processing
