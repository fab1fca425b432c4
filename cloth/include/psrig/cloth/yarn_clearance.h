#pragma once
// How close yarns come to each other where they have been placed: the
// smallest distance between two points of yarn that may touch, over the
// distance at which they touch (yarn_cell.h's contact: the section's
// contact radius across, its half-thickness along the cloth's normal), so
// 1 is touching and below 1 is yarn passing into yarn. Points of one yarn
// closer along it than half a turn round its section do not count.
// Measured on a whole placed cloth, on a curved one too (each point's own
// normal splits the offset).

#include "psrig/cloth/yarn_cell.h"
#include "psrig/cloth/yarn_curves.h"

namespace psrig::cloth {

struct YarnClearance {
  float clearance = 0;
  int curve_a = 0, point_a = 0, curve_b = 0, point_b = 0;  // the closest pair
};

[[nodiscard]] YarnClearance min_clearance(const YarnSet& yarns, const YarnSection& section);

}  // namespace psrig::cloth
