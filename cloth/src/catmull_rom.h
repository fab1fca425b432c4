#pragma once
// Catmull-Rom's weights of the four control points p0..p3 at t in [0, 1]
// (the curve through p1 at 0 and p2 at 1), which the yarn splines and the
// knit cell's samples share.

#include <Eigen/Core>

namespace psrig::cloth {

[[nodiscard]] inline Eigen::Vector4f catmull_rom_weights(float t) {
  const float t2 = t * t, t3 = t2 * t;
  return 0.5f *
         Eigen::Vector4f(-t + 2 * t2 - t3, 2 - 5 * t2 + 3 * t3, t + 4 * t2 - 3 * t3, -t2 + t3);
}

}  // namespace psrig::cloth
