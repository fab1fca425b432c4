#include "psrig/cloth/knot_relaxation.h"

#include <algorithm>
#include <cmath>
#include <type_traits>

#include <Eigen/Geometry>

namespace psrig::cloth {
namespace {

// The maths below is written once for a T that is either float (one knot)
// or Lanes: four knots side by side in vector lanes (GCC's vector
// extension: SSE/AVX on x86, NEON on ARM, plain loops elsewhere). Each
// lane does exactly the float arithmetic of a single knot.
constexpr int kLanes = 4;
using Lanes = float __attribute__((vector_size(kLanes * sizeof(float))));
using LaneMask = int __attribute__((vector_size(kLanes * sizeof(int))));

template <class T>
using MaskOf = std::conditional_t<std::is_same_v<T, float>, bool, LaneMask>;

float lane_max(float a, float b) {
  return std::max(a, b);
}
Lanes lane_max(Lanes a, Lanes b) {
  return a > b ? a : b;
}
float lane_abs(float a) {
  return std::abs(a);
}
Lanes lane_abs(Lanes a) {
  return a < 0 ? -a : a;
}
float lane_sqrt(float a) {
  return std::sqrt(a);
}
Lanes lane_sqrt(Lanes a) {
  Lanes out{};
  for (int i = 0; i < kLanes; ++i)
    out[i] = std::sqrt(a[i]);
  return out;
}
void lane_sincos(float angle, float& c, float& s) {
  c = std::cos(angle);
  s = std::sin(angle);
}
void lane_sincos(Lanes angle, Lanes& c, Lanes& s) {
  for (int i = 0; i < kLanes; ++i) {
    c[i] = std::cos(angle[i]);
    s[i] = std::sin(angle[i]);
  }
}
float select(bool mask, float a, float b) {
  return mask ? a : b;
}
Lanes select(LaneMask mask, Lanes a, Lanes b) {
  return mask ? a : b;
}
bool both(bool a, bool b) {
  return a && b;
}
LaneMask both(LaneMask a, LaneMask b) {
  return a & b;
}
bool either(bool a, bool b) {
  return a || b;
}
LaneMask either(LaneMask a, LaneMask b) {
  return a | b;
}
bool lane_not(bool a) {
  return !a;
}
LaneMask lane_not(LaneMask a) {
  return ~a;
}
bool any(bool mask) {
  return mask;
}
bool any(LaneMask mask) {
  for (int i = 0; i < kLanes; ++i)
    if (mask[i] != 0) return true;
  return false;
}
template <class Mask>
Mask all_set() {
  if constexpr (std::is_same_v<Mask, bool>)
    return true;
  else
    return Mask{} - 1;
}

template <class T>
struct V3 {
  T x, y, z;
  V3 operator-(const V3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  V3 operator*(T k) const { return {x * k, y * k, z * k}; }
  T dot(const V3& o) const { return x * o.x + y * o.y + z * o.z; }
};

template <class T>
struct V2 {
  T x, y;
  V2 operator-(const V2& o) const { return {x - o.x, y - o.y}; }
  V2 operator-() const { return {-x, -y}; }
  T dot(const V2& o) const { return x * o.x + y * o.y; }
};

// Everything works in the knot's own frame (e1, e2, n) about its centre:
// there the three moving points are short closed forms of (cos theta,
// sin theta, l), and every derivative lies in the plane (the lifts along n
// do not move), so a Jacobian row is two 2-vector dots. The fixed
// neighbours are brought into that frame once per relaxation.
template <class T>
struct LocalPass {
  V3<T> before, after;
  T side, lift_enter, lift_leave;
  std::array<T, 4> inverse_rest_length;
  std::array<T, 3> rest_cosine;
};

LocalPass<float> to_local(const KnotPlacement& knot, const KnotPass& pass) {
  const auto local = [&](const Eigen::Vector3f& world) {
    const Eigen::Vector3f offset = world - knot.centre;
    return V3<float>{offset.dot(knot.frame.e1), offset.dot(knot.frame.e2),
                     offset.dot(knot.frame.normal)};
  };
  LocalPass<float> out{local(pass.before),
                       local(pass.after),
                       pass.side,
                       pass.lift_enter * knot.radius,
                       pass.lift_leave * knot.radius,
                       {},
                       pass.rest_cosine};
  for (std::size_t i = 0; i < 4; ++i)
    out.inverse_rest_length[i] = 1 / std::max(pass.rest_length[i], 1e-6f);
  return out;
}

// Energy and, when asked, the Gauss-Newton normal equations (A = J^T J,
// g = J^T r; A symmetric, so three numbers).
template <class T>
struct Residuals {
  T energy{}, a_tt{}, a_tl{}, a_ll{}, g_t{}, g_l{};

  void add(T residual, T by_theta, T by_length) {
    energy += residual * residual;
    a_tt += by_theta * by_theta;
    a_tl += by_theta * by_length;
    a_ll += by_length * by_length;
    g_t += by_theta * residual;
    g_l += by_length * residual;
  }
};

template <class T, class Mask>
Residuals<T> select(Mask mask, const Residuals<T>& a, const Residuals<T>& b) {
  return {select(mask, a.energy, b.energy), select(mask, a.a_tt, b.a_tt),
          select(mask, a.a_tl, b.a_tl),     select(mask, a.a_ll, b.a_ll),
          select(mask, a.g_t, b.g_t),       select(mask, a.g_l, b.g_l)};
}

// An edge of the chain: its direction and length, and how it moves with
// theta and l.
template <class T>
struct Edge {
  V3<T> unit;
  T length;
  V2<T> by_theta, by_length;
};

template <bool with_jacobian, class T>
void add_pass(Residuals<T>& residuals, const LocalPass<T>& pass, T c, T s, T l, T r,
              float angle_scale, float length_scale) {
  // The chain before, enter, beside, leave, after. The enter point moves by
  // (l s, -l c) with theta and (-c, -s) with l; the leave point by the
  // opposite; the beside point by side r (c, s) with theta only.
  const T sr = pass.side * r;
  const V3<T> enter{-l * c, -l * s, pass.lift_enter};
  const V3<T> beside{sr * s, -sr * c, T{}};
  const V3<T> leave{l * c, l * s, pass.lift_leave};
  const V2<T> enter_t{l * s, -l * c}, enter_l{-c, -s}, beside_t{sr * c, sr * s};
  const std::array<V3<T>, 4> vectors{enter - pass.before, beside - enter, leave - beside,
                                     pass.after - leave};
  const std::array<V2<T>, 4> by_theta{enter_t, beside_t - enter_t, -enter_t - beside_t, enter_t};
  const std::array<V2<T>, 4> by_length{enter_l, -enter_l, -enter_l, enter_l};
  std::array<Edge<T>, 4> edges;
  for (std::size_t i = 0; i < 4; ++i) {
    const T length = lane_max(lane_sqrt(vectors[i].dot(vectors[i])), T{} + 1e-6f);
    edges[i] = {vectors[i] * (1.0f / length), length, by_theta[i], by_length[i]};
    // Stretching, relative to the rest length: d|e|/de = unit.
    const T stretch = length * pass.inverse_rest_length[i] - 1.0f;
    if constexpr (with_jacobian) {
      const V2<T> unit{edges[i].unit.x, edges[i].unit.y};
      const T scale = length_scale * pass.inverse_rest_length[i];
      residuals.add(length_scale * stretch, scale * unit.dot(by_theta[i]),
                    scale * unit.dot(by_length[i]));
    } else {
      residuals.energy += length_scale * length_scale * stretch * stretch;
    }
  }
  for (std::size_t i = 0; i < 3; ++i) {
    // Bending: the cosine between consecutive edges against its rest value.
    const Edge<T>& e0 = edges[i];
    const Edge<T>& e1 = edges[i + 1];
    const T cosine = e0.unit.dot(e1.unit);
    const T bend = cosine - pass.rest_cosine[i];
    if constexpr (with_jacobian) {
      // d(u0 . u1)/d e0 = (u1 - cos u0) / |e0|, and likewise for e1.
      const T inverse0 = 1.0f / e0.length, inverse1 = 1.0f / e1.length;
      const V2<T> by_edge0{(e1.unit.x - cosine * e0.unit.x) * inverse0,
                           (e1.unit.y - cosine * e0.unit.y) * inverse0};
      const V2<T> by_edge1{(e0.unit.x - cosine * e1.unit.x) * inverse1,
                           (e0.unit.y - cosine * e1.unit.y) * inverse1};
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

template <class T>
struct LocalKnot {
  std::array<LocalPass<T>, kMaxPasses> passes{};
  std::size_t count = 0;
  T radius{};
  float angle_scale = 0, length_scale = 0;

  template <bool with_jacobian>
  [[nodiscard]] Residuals<T> evaluate(T theta, T half_length) const {
    Residuals<T> residuals;
    T c{}, s{};
    lane_sincos(theta, c, s);
    for (std::size_t p = 0; p < count; ++p)
      add_pass<with_jacobian>(residuals, passes[p], c, s, half_length, radius, angle_scale,
                              length_scale);
    return residuals;
  }
};

LocalKnot<float> to_local(const KnotPlacement& knot, std::span<const KnotPass> world,
                          KnotWeights weights) {
  LocalKnot<float> local;
  local.count = std::min(world.size(), kMaxPasses);
  local.radius = knot.radius;
  local.angle_scale = std::sqrt(weights.angle);
  local.length_scale = std::sqrt(weights.length);
  for (std::size_t p = 0; p < local.count; ++p)
    local.passes[p] = to_local(knot, world[p]);
  return local;
}

// One knot into one lane of four (all four hold the same number of passes).
void set_lane(LocalKnot<Lanes>& lanes, int lane, const LocalKnot<float>& one) {
  lanes.count = one.count;
  lanes.angle_scale = one.angle_scale;
  lanes.length_scale = one.length_scale;
  lanes.radius[lane] = one.radius;
  for (std::size_t p = 0; p < one.count; ++p) {
    LocalPass<Lanes>& to = lanes.passes[p];
    const LocalPass<float>& from = one.passes[p];
    to.before.x[lane] = from.before.x;
    to.before.y[lane] = from.before.y;
    to.before.z[lane] = from.before.z;
    to.after.x[lane] = from.after.x;
    to.after.y[lane] = from.after.y;
    to.after.z[lane] = from.after.z;
    to.side[lane] = from.side;
    to.lift_enter[lane] = from.lift_enter;
    to.lift_leave[lane] = from.lift_leave;
    for (std::size_t i = 0; i < 4; ++i)
      to.inverse_rest_length[i][lane] = from.inverse_rest_length[i];
    for (std::size_t i = 0; i < 3; ++i)
      to.rest_cosine[i][lane] = from.rest_cosine[i];
  }
}

// Gauss-Newton from (theta, half_length), in place. Where a lane stops (no
// descent, converged, a singular system) it keeps its state while the
// others go on.
template <class T>
void gauss_newton(const LocalKnot<T>& local, T& theta, T& half_length, int iterations) {
  using Mask = MaskOf<T>;
  const T shortest = 0.1f * local.radius;
  Residuals<T> residuals = local.template evaluate<true>(theta, half_length);
  Mask active = all_set<Mask>();
  for (int iteration = 0; iteration < iterations && any(active); ++iteration) {
    // A touch of damping keeps the 2x2 solve well posed when one parameter
    // barely moves the residuals (e.g. a straight, unstretched pass).
    const T damping = 1e-6f + 1e-4f * (residuals.a_tt + residuals.a_ll);
    const T a = residuals.a_tt + damping, b = residuals.a_tl, d = residuals.a_ll + damping;
    const T determinant = a * d - b * b;
    active = both(active, determinant > 0);
    const T divisor = select(active, determinant, T{} + 1.0f);
    const T step_theta = (b * residuals.g_l - d * residuals.g_t) / divisor;
    const T step_length = (b * residuals.g_t - a * residuals.g_l) / divisor;
    T next_theta = theta + step_theta;
    T next_length = lane_max(half_length + step_length, shortest);
    // Gauss-Newton may overshoot on these non-quadratic energies: halve the
    // step until the energy does not rise, or keep the state. The last
    // iteration needs only the energy; the others get the next iteration's
    // normal equations from the same evaluation.
    const bool last = iteration + 1 == iterations;
    Mask lower{};
    Residuals<T> at_next = residuals;
    for (int halving = 0; halving < 3; ++halving) {
      const Residuals<T> trial = last ? local.template evaluate<false>(next_theta, next_length)
                                      : local.template evaluate<true>(next_theta, next_length);
      const Mask accepted = both(both(active, lane_not(lower)), trial.energy <= residuals.energy);
      at_next = select(accepted, trial, at_next);
      lower = either(lower, accepted);
      const Mask halve = both(active, lane_not(lower));
      if (!any(halve)) break;
      next_theta = select(halve, 0.5f * (theta + next_theta), next_theta);
      next_length = select(halve, 0.5f * (half_length + next_length), next_length);
    }
    active = both(active, lower);
    theta = select(active, next_theta, theta);
    half_length = select(active, next_length, half_length);
    residuals = select(active, at_next, residuals);
    // Converged (a thousandth of a degree, a micrometre): the rest is noise.
    active = both(active, lane_not(both(lane_abs(step_theta) < 2e-5f,
                                        lane_abs(step_length) < 1e-3f * local.radius)));
  }
}

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
  return to_local(knot, passes, weights).evaluate<false>(state.theta, state.half_length).energy;
}

KnotState relax_knot(const KnotPlacement& knot, KnotState state, std::span<const KnotPass> passes,
                     int iterations, KnotWeights weights) {
  if (passes.empty()) return state;
  gauss_newton(to_local(knot, passes, weights), state.theta, state.half_length, iterations);
  return state;
}

void relax_knots(std::span<const KnotProblem> problems, int iterations, KnotWeights weights,
                 std::span<KnotState> out) {
  std::array<std::size_t, kLanes> batch{};
  int filled = 0;
  const auto run_batch = [&] {
    // Lanes past `filled` repeat the first knot; their answers are dropped.
    LocalKnot<Lanes> lanes;
    Lanes theta{}, half_length{};
    for (int lane = 0; lane < kLanes; ++lane) {
      const KnotProblem& problem =
          problems[batch[static_cast<std::size_t>(lane < filled ? lane : 0)]];
      set_lane(lanes, lane, to_local(*problem.knot, problem.passes, weights));
      theta[lane] = problem.initial.theta;
      half_length[lane] = problem.initial.half_length;
    }
    gauss_newton(lanes, theta, half_length, iterations);
    for (int lane = 0; lane < filled; ++lane)
      out[batch[static_cast<std::size_t>(lane)]] = {theta[lane], half_length[lane]};
    filled = 0;
  };
  for (std::size_t i = 0; i < problems.size(); ++i) {
    const KnotProblem& problem = problems[i];
    // Batched: knots with the two passes of a knit knot (the rest, e.g. the
    // fabric's top and bottom edges, one at a time).
    if (problem.passes.size() == 2) {
      batch[static_cast<std::size_t>(filled++)] = i;
      if (filled == kLanes) run_batch();
    } else {
      out[i] = relax_knot(*problem.knot, problem.initial, problem.passes, iterations, weights);
    }
  }
  if (filled > 0) run_batch();
}

}  // namespace psrig::cloth
