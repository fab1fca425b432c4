#include "psrig/preview/knot_relaxation.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace psrig::preview {
namespace {

// Everything below works in the knot's own frame (e1, e2, n) about its
// centre: there the three moving points are short closed forms of
// (cos theta, sin theta, l), and every derivative lies in the plane (the
// lifts along n do not move), so a Jacobian row is two 2-vector dots. The
// fixed neighbours are brought into that frame once per relaxation.
struct LocalPass {
  std::array<Eigen::Vector3f, 2> fixed;  // before, after
  float side = 1, lift_enter = 0, lift_leave = 0;
  std::array<float, 4> inverse_rest_length{};
  std::array<float, 3> rest_cosine{};
};

LocalPass to_local(const KnotPlacement& knot, const KnotPass& pass) {
  const auto local = [&](const Eigen::Vector3f& world) {
    const Eigen::Vector3f offset = world - knot.centre;
    return Eigen::Vector3f(offset.dot(knot.frame.e1), offset.dot(knot.frame.e2),
                           offset.dot(knot.frame.normal));
  };
  LocalPass out{{local(pass.before), local(pass.after)}, pass.side, pass.lift_enter * knot.radius,
                pass.lift_leave * knot.radius,           {},        pass.rest_cosine};
  for (std::size_t i = 0; i < 4; ++i)
    out.inverse_rest_length[i] = 1 / std::max(pass.rest_length[i], 1e-6f);
  return out;
}

// Energy and, when asked, the Gauss-Newton normal equations (A = J^T J,
// g = J^T r; A symmetric, so three numbers).
struct Residuals {
  float energy = 0;
  float a_tt = 0, a_tl = 0, a_ll = 0;
  float g_t = 0, g_l = 0;

  void add(float residual, float by_theta, float by_length) {
    energy += residual * residual;
    a_tt += by_theta * by_theta;
    a_tl += by_theta * by_length;
    a_ll += by_length * by_length;
    g_t += by_theta * residual;
    g_l += by_length * residual;
  }
};

struct Vec2 {
  float x, y;
  [[nodiscard]] float dot(Vec2 other) const { return x * other.x + y * other.y; }
};

// An edge of the chain: its direction and length, and how it moves with
// theta and l (in-plane vectors: the lifts along n are fixed).
struct Edge {
  Eigen::Vector3f unit;
  float length;
  Vec2 by_theta, by_length;
};

template <bool with_jacobian>
void add_pass(Residuals& residuals, const LocalPass& pass, float c, float s, float l, float r,
              float angle_scale, float length_scale) {
  // The chain before, enter, beside, leave, after. The enter point moves by
  // (l s, -l c) with theta and (-c, -s) with l; the leave point by the
  // opposite; the beside point by side r (c, s) with theta only.
  const float sr = pass.side * r;
  const Eigen::Vector3f enter(-l * c, -l * s, pass.lift_enter);
  const Eigen::Vector3f beside(sr * s, -sr * c, 0);
  const Eigen::Vector3f leave(l * c, l * s, pass.lift_leave);
  const Vec2 enter_t{l * s, -l * c}, enter_l{-c, -s}, beside_t{sr * c, sr * s};
  const std::array<Eigen::Vector3f, 4> vectors{enter - pass.fixed[0], beside - enter,
                                               leave - beside, pass.fixed[1] - leave};
  const std::array<Vec2, 4> by_theta{enter_t,
                                     {beside_t.x - enter_t.x, beside_t.y - enter_t.y},
                                     {-enter_t.x - beside_t.x, -enter_t.y - beside_t.y},
                                     enter_t};
  const std::array<Vec2, 4> by_length{
      enter_l, {-enter_l.x, -enter_l.y}, {-enter_l.x, -enter_l.y}, enter_l};
  std::array<Edge, 4> edges;
  for (std::size_t i = 0; i < 4; ++i) {
    const float length = std::max(vectors[i].norm(), 1e-6f);
    edges[i] = {vectors[i] * (1 / length), length, by_theta[i], by_length[i]};
    // Stretching, relative to the rest length: d|e|/de = unit.
    const float stretch = length * pass.inverse_rest_length[i] - 1;
    if constexpr (with_jacobian) {
      const Vec2 unit{edges[i].unit.x(), edges[i].unit.y()};
      const float scale = length_scale * pass.inverse_rest_length[i];
      residuals.add(length_scale * stretch, scale * unit.dot(by_theta[i]),
                    scale * unit.dot(by_length[i]));
    } else {
      residuals.energy += length_scale * length_scale * stretch * stretch;
    }
  }
  for (std::size_t i = 0; i < 3; ++i) {
    // Bending: the cosine between consecutive edges against its rest value.
    const Edge& e0 = edges[i];
    const Edge& e1 = edges[i + 1];
    const float cosine = e0.unit.dot(e1.unit);
    const float bend = cosine - pass.rest_cosine[i];
    if constexpr (with_jacobian) {
      // d(u0 . u1)/d e0 = (u1 - cos u0) / |e0|, and likewise for e1.
      const float inverse0 = 1 / e0.length, inverse1 = 1 / e1.length;
      const Vec2 by_edge0{(e1.unit.x() - cosine * e0.unit.x()) * inverse0,
                          (e1.unit.y() - cosine * e0.unit.y()) * inverse0};
      const Vec2 by_edge1{(e0.unit.x() - cosine * e1.unit.x()) * inverse1,
                          (e0.unit.y() - cosine * e1.unit.y()) * inverse1};
      residuals.add(angle_scale * bend,
                    angle_scale * (by_edge0.dot(e0.by_theta) + by_edge1.dot(e1.by_theta)),
                    angle_scale * (by_edge0.dot(e0.by_length) + by_edge1.dot(e1.by_length)));
    } else {
      residuals.energy += angle_scale * angle_scale * bend * bend;
    }
  }
}

// A knot holds two yarns; a woven crossing or a test may hand it a few more.
constexpr std::size_t kMaxPasses = 4;

struct LocalKnot {
  std::array<LocalPass, kMaxPasses> passes;
  std::size_t count = 0;
  float radius = 0;
  float angle_scale = 0, length_scale = 0;

  LocalKnot(const KnotPlacement& knot, std::span<const KnotPass> world, KnotWeights weights)
      : count(std::min(world.size(), kMaxPasses)),
        radius(knot.radius),
        angle_scale(std::sqrt(weights.angle)),
        length_scale(std::sqrt(weights.length)) {
    for (std::size_t p = 0; p < count; ++p)
      passes[p] = to_local(knot, world[p]);
  }

  template <bool with_jacobian>
  [[nodiscard]] Residuals evaluate(KnotState state) const {
    Residuals residuals;
    const float c = std::cos(state.theta), s = std::sin(state.theta);
    for (std::size_t p = 0; p < count; ++p)
      add_pass<with_jacobian>(residuals, passes[p], c, s, state.half_length, radius, angle_scale,
                              length_scale);
    return residuals;
  }
};

}  // namespace

KnotPoints knot_points(const KnotPlacement& knot, KnotState state, const KnotPass& pass) {
  const float c = std::cos(state.theta), s = std::sin(state.theta);
  const Eigen::Vector3f d = c * knot.frame.e1 + s * knot.frame.e2;
  const Eigen::Vector3f b = s * knot.frame.e1 - c * knot.frame.e2;  // d x n
  const Eigen::Vector3f& n = knot.frame.normal;
  const float r = knot.radius, l = state.half_length;
  return {knot.centre - l * d + pass.lift_enter * r * n, knot.centre + pass.side * r * b,
          knot.centre + l * d + pass.lift_leave * r * n};
}

void record_rest_shape(KnotPass& pass, const KnotPoints& points) {
  const std::array<Eigen::Vector3f, 5> x{pass.before, points.enter, points.beside, points.leave,
                                         pass.after};
  std::array<Eigen::Vector3f, 4> unit;
  for (std::size_t i = 0; i < 4; ++i) {
    const Eigen::Vector3f edge = x[i + 1] - x[i];
    pass.rest_length[i] = edge.norm();
    unit[i] = edge.normalized();
  }
  for (std::size_t i = 0; i < 3; ++i)
    pass.rest_cosine[i] = unit[i].dot(unit[i + 1]);
}

float knot_energy(const KnotPlacement& knot, KnotState state, std::span<const KnotPass> passes,
                  KnotWeights weights) {
  return LocalKnot(knot, passes, weights).evaluate<false>(state).energy;
}

KnotState relax_knot(const KnotPlacement& knot, KnotState state, std::span<const KnotPass> passes,
                     int iterations, KnotWeights weights) {
  if (passes.empty()) return state;
  const LocalKnot local(knot, passes, weights);
  const float shortest = 0.1f * knot.radius;
  Residuals residuals = local.evaluate<true>(state);
  for (int iteration = 0; iteration < iterations; ++iteration) {
    // A touch of damping keeps the 2x2 solve well posed when one parameter
    // barely moves the residuals (e.g. a straight, unstretched pass).
    const float damping = 1e-6f + 1e-4f * (residuals.a_tt + residuals.a_ll);
    const float a = residuals.a_tt + damping, b = residuals.a_tl, d = residuals.a_ll + damping;
    const float determinant = a * d - b * b;
    if (!(determinant > 0)) break;
    const Eigen::Vector2f step((b * residuals.g_l - d * residuals.g_t) / determinant,
                               (b * residuals.g_t - a * residuals.g_l) / determinant);
    KnotState next{state.theta + step.x(), std::max(state.half_length + step.y(), shortest)};
    // Gauss-Newton may overshoot on these non-quadratic energies: halve the
    // step until the energy does not rise, or keep the state. The last
    // iteration needs only the energy; the others get the next iteration's
    // normal equations from the same evaluation.
    const bool last = iteration + 1 == iterations;
    bool lower = false;
    Residuals at_next;
    for (int halving = 0; halving < 3 && !lower; ++halving) {
      at_next = last ? local.evaluate<false>(next) : local.evaluate<true>(next);
      lower = at_next.energy <= residuals.energy;
      if (!lower)
        next = {0.5f * (state.theta + next.theta), 0.5f * (state.half_length + next.half_length)};
    }
    if (!lower) break;
    state = next;
    residuals = at_next;
    // Converged (a thousandth of a degree, a micrometre): the rest is noise.
    if (std::abs(step.x()) < 2e-5f && std::abs(step.y()) < 1e-3f * knot.radius) break;
  }
  return state;
}

}  // namespace psrig::preview
