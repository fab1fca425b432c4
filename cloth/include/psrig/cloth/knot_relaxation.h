#pragma once
// The knot-based yarn representation of huang2025-realtime-knit-deformation-
// rendering.txt (section 3): where two yarns interlock, a knot centred at x_k
// holds both. Each yarn enters at a contact point x_k - l d, passes beside
// the centre at x_k +/- r b (b = d x n, the two yarns 2r apart), and leaves at
// x_k + l d, lifted by +/- r along n at the contacts so that one yarn lies
// over the other at one contact and under it at the other (eq. 1, 2).
//
// When the cloth deforms, the knot centre follows the stitch mesh and the
// knot's two free parameters, its tilt theta (d's angle in the face) and half
// length l, are relaxed by Gauss-Newton on the bending (angle) and stretching
// (length) energies of eq. 5, 6 against the yarns' rest shapes. The
// constraints of eq. 4 (midpoints at x_k, |p0 - p1| = 2r, d perpendicular to
// b) hold by construction of this parameterisation.

#include <array>
#include <span>

#include <Eigen/Core>

#include "psrig/cloth/stitch_mesh.h"

namespace psrig::cloth {

struct KnotState {
  float theta = 0;  // radians, d = cos(theta) e1 + sin(theta) e2
  float half_length = 0;
};

// Where a knot sits this frame.
struct KnotPlacement {
  Eigen::Vector3f centre;
  FaceFrame frame;
  float radius = 0;  // the yarn's: the two yarns pass 2 radius apart
};

// One yarn through a knot: its three points (enter, beside, leave) and the
// fixed control points just before and after them on the same yarn.
struct KnotPass {
  float side = 1;        // +1: passes at x_k + r b (p0); -1: at x_k - r b (p1)
  float lift_enter = 0;  // in radii along n, at x_k - l d
  float lift_leave = 0;  // at x_k + l d
  Eigen::Vector3f before, after;
  // Rest shape of the five points before, enter, beside, leave, after.
  std::array<float, 4> rest_length{};
  std::array<float, 3> rest_cosine{};  // of the angles at enter, beside, leave
};

struct KnotPoints {
  Eigen::Vector3f enter, beside, leave;
};

[[nodiscard]] KnotPoints knot_points(const KnotPlacement& knot, KnotState state,
                                     const KnotPass& pass);

// Records a pass's rest lengths and angles from its points as they are now.
void record_rest_shape(KnotPass& pass, const KnotPoints& points);

// Bending weighs more than stretching: a cosine changes little for small
// turns, and yarn keeps its curl (the paper's "fiber memory").
struct KnotWeights {
  float angle = 4;
  float length = 1;  // on relative length change
};

// Eq. 3 over the passes' five-point chains.
[[nodiscard]] float knot_energy(const KnotPlacement& knot, KnotState state,
                                std::span<const KnotPass> passes, KnotWeights weights = {});

// Gauss-Newton from `state`: A = sum J J^T, b = -sum J r per iteration.
[[nodiscard]] KnotState relax_knot(const KnotPlacement& knot, KnotState state,
                                   std::span<const KnotPass> passes, int iterations,
                                   KnotWeights weights = {});

// One knot for relax_knots: where it sits, its passes, where to start.
struct KnotProblem {
  const KnotPlacement* knot = nullptr;
  std::span<const KnotPass> passes;
  KnotState initial;
};

// relax_knot() over many knots, out[i] for problems[i]. Knots with two
// passes (every knit knot but the fabric's edges) go four at a time
// through vector lanes, each lane doing the same arithmetic as one knot.
void relax_knots(std::span<const KnotProblem> problems, int iterations, KnotWeights weights,
                 std::span<KnotState> out);

}  // namespace psrig::cloth
