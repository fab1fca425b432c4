#pragma once
// A yarn's control points to its drawn centreline: a Catmull-Rom spline (the
// cubic cardinal spline chen2003-lumislice-knitwear.txt interpolates its key
// points with) through the positions; normals, lifts and colours follow
// linearly.

#include <span>

#include <Eigen/Core>

#include "psrig/cloth/yarn_curves.h"

namespace psrig::cloth {

struct YarnControlPoint {
  Eigen::Vector3f position, normal;
  float lift = 0;  // in yarn radii (YarnCurve::lift)
  Eigen::Vector3f colour = Eigen::Vector3f::Zero();
};

// samples_per_span points from each control point to the next, then the last
// point; `curve`'s storage is reused. Without `coloured`, curve.colours is
// left empty (the style's colour).
void sample_yarn(std::span<const YarnControlPoint> control, int samples_per_span, bool coloured,
                 YarnCurve& curve);

}  // namespace psrig::cloth
