#pragma once
// Yarns seen head-on by an orthographic camera: a height field of the
// topmost yarn surface and which yarn it is, where along it and where
// across it. Each yarn is a chain of capsules with a rounded (half-ellipse)
// cross-section, and the topmost yarn wins at each pixel. The simulated
// camera's world is rasterised this way, and the cloth's cover factor is
// measured on it.
//
// The section stops where the ellipse steepens past `max_slope`; what lies
// beyond (the flank of a yarn and the crease under it) is left to the
// caller (the simulator fills it with fibres).
//
// The image is cut into bands of rows and each segment is drawn only into the
// bands it touches, highest first, so every pixel tests only the few segments
// near it and rejects most of them at a glance; bands run in parallel and
// each pixel sees its segments in one fixed order, so the result does not
// depend on the thread count.

#include <span>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "psrig/cloth/yarn_curves.h"

namespace psrig::cloth {

struct RasterVertex {
  double x = 0;  // mm, image axes: x to the right, y down the rows
  double y = 0;
  double z = 0;  // height of the centreline, mm
};

struct RasterYarn {
  std::vector<RasterVertex> path;
  double half_width_mm = 0.2;   // of the flattened cross-section, in the image plane
  double half_height_mm = 0.1;  // above the centreline
};

struct YarnRaster {
  cv::Mat top;     // CV_32F: height of the topmost yarn surface, mm (floor where none)
  cv::Mat yarn;    // CV_32S: index of that yarn, -1 where none
  cv::Mat along;   // CV_32F: arc length along its centreline, mm
  cv::Mat across;  // CV_32F: signed distance from its centreline over the half-width, [-1, 1]
};

[[nodiscard]] YarnRaster rasterize_yarns(std::span<const RasterYarn> yarns, cv::Size size,
                                         double px, float floor_mm, double max_slope);

// A set of cloth yarns (y up, front toward +z) as seen head-on over the
// region [x0, x0 + size.width px) x [y0, y0 + size.height px) of the cloth's
// plane, row 0 at the top (y0 + height).
[[nodiscard]] std::vector<RasterYarn> raster_yarns(const YarnSet& yarns, Eigen::Vector2d origin_mm,
                                                   cv::Size size, double px);

// The fraction of the region covered by yarn, seen head-on (issue 18's
// cover factor; 1 - the open area).
[[nodiscard]] double cover_factor(const YarnSet& yarns, Eigen::Vector2d origin_mm,
                                  Eigen::Vector2d size_mm, double px);

}  // namespace psrig::cloth
