#pragma once
// Ambient occlusion from a height map, for glTF's occlusionTexture: how much
// of the sky above each point the surface around it hides. A horizon-based
// estimate (Bavoil, Sainz and Dimitrov, "Image-Space Horizon-Based Ambient
// Occlusion", SIGGRAPH 2008 talks): along each of 8 directions the highest
// horizon within `radius` is found, and the point keeps 1 - the mean over
// directions of sin(horizon elevation) - sin(tangent elevation) (the
// surface's own slope along the direction; the horizon never below it). A
// plane, tilted or not, is 1 everywhere; the bottom of a V groove whose walls
// rise at 45 degrees keeps 0.53.

#include <opencv2/core.hpp>

namespace psrig::export_ {

// `height` (CV_32F, NaN where unknown: taken as the lowest height) in the
// units of `pixel_size` (mm per pixel, or 1 for heights in pixels);
// `radius_px` how far the horizon is looked for. CV_32F in [0, 1].
[[nodiscard]] cv::Mat ambient_occlusion(const cv::Mat& height, double pixel_size, int radius_px);

}  // namespace psrig::export_
