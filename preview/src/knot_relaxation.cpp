#include "psrig/preview/knot_relaxation.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace psrig::preview {
namespace {

// A chain point and its derivatives by theta and l.
struct ChainPoint {
  Eigen::Vector3f x, by_theta, by_length;
};

struct Residuals {
  // Up to 4 length and 3 angle residuals per pass.
  float energy = 0;
  Eigen::Matrix2f normal_matrix = Eigen::Matrix2f::Zero();
  Eigen::Vector2f gradient = Eigen::Vector2f::Zero();

  void add(float residual, const Eigen::Vector2f& jacobian) {
    energy += residual * residual;
    normal_matrix += jacobian * jacobian.transpose();
    gradient += jacobian * residual;
  }
};

// The knot's in-plane directions for one state, shared by its passes.
struct Directions {
  Eigen::Vector3f d, d_perp, b;  // d_perp: d by theta; b = d x n, whose derivative by theta is d

  Directions(const KnotPlacement& knot, KnotState state) {
    const float c = std::cos(state.theta), s = std::sin(state.theta);
    d = c * knot.frame.e1 + s * knot.frame.e2;
    d_perp = -s * knot.frame.e1 + c * knot.frame.e2;
    b = s * knot.frame.e1 - c * knot.frame.e2;
  }
};

std::array<Eigen::Vector3f, 5> chain_points(const KnotPlacement& knot, const Directions& axes,
                                            float half_length, const KnotPass& pass) {
  const float r = knot.radius;
  const Eigen::Vector3f& n = knot.frame.normal;
  return {pass.before, knot.centre - half_length * axes.d + pass.lift_enter * r * n,
          knot.centre + pass.side * r * axes.b,
          knot.centre + half_length * axes.d + pass.lift_leave * r * n, pass.after};
}

std::array<ChainPoint, 5> chain(const KnotPlacement& knot, const Directions& axes,
                                float half_length, const KnotPass& pass) {
  const std::array<Eigen::Vector3f, 5> x = chain_points(knot, axes, half_length, pass);
  const Eigen::Vector3f zero = Eigen::Vector3f::Zero();
  const float l = half_length;
  return {{
      {x[0], zero, zero},
      {x[1], -l * axes.d_perp, -axes.d},
      {x[2], pass.side * knot.radius * axes.d, zero},
      {x[3], l * axes.d_perp, axes.d},
      {x[4], zero, zero},
  }};
}

Eigen::Vector2f derivative(const ChainPoint& point, const Eigen::Vector3f& by_point) {
  return {by_point.dot(point.by_theta), by_point.dot(point.by_length)};
}

void add_pass(Residuals& residuals, const KnotPlacement& knot, const Directions& axes,
              float half_length, const KnotPass& pass, float angle_scale, float length_scale) {
  const std::array<ChainPoint, 5> points = chain(knot, axes, half_length, pass);
  std::array<Eigen::Vector3f, 4> unit;
  std::array<float, 4> length;
  for (std::size_t i = 0; i < 4; ++i) {
    const Eigen::Vector3f edge = points[i + 1].x - points[i].x;
    length[i] = std::max(edge.norm(), 1e-6f);
    unit[i] = edge / length[i];
    // Stretching, relative to the rest length: d|e|/dx_{i+1} = unit.
    const float rest = std::max(pass.rest_length[i], 1e-6f);
    const Eigen::Vector2f jacobian =
        (derivative(points[i + 1], unit[i]) - derivative(points[i], unit[i])) / rest;
    residuals.add(length_scale * (length[i] / rest - 1), length_scale * jacobian);
  }
  for (std::size_t i = 0; i < 3; ++i) {
    // Bending: the cosine between consecutive edges against its rest value.
    const float cosine = unit[i].dot(unit[i + 1]);
    // d(u0 . u1)/d e0 = (u1 - cos u0) / |e0|, and likewise for e1.
    const Eigen::Vector3f by_edge0 = (unit[i + 1] - cosine * unit[i]) / length[i];
    const Eigen::Vector3f by_edge1 = (unit[i] - cosine * unit[i + 1]) / length[i + 1];
    const Eigen::Vector2f jacobian =
        derivative(points[i + 1], by_edge0) - derivative(points[i], by_edge0) +
        derivative(points[i + 2], by_edge1) - derivative(points[i + 1], by_edge1);
    residuals.add(angle_scale * (cosine - pass.rest_cosine[i]), angle_scale * jacobian);
  }
}

Residuals evaluate(const KnotPlacement& knot, KnotState state, std::span<const KnotPass> passes,
                   KnotWeights weights) {
  Residuals residuals;
  const float angle_scale = std::sqrt(weights.angle), length_scale = std::sqrt(weights.length);
  const Directions axes(knot, state);
  for (const KnotPass& pass : passes)
    add_pass(residuals, knot, axes, state.half_length, pass, angle_scale, length_scale);
  return residuals;
}

// The energy alone, for the step control: no derivatives.
float energy_only(const KnotPlacement& knot, KnotState state, std::span<const KnotPass> passes,
                  KnotWeights weights) {
  const Directions axes(knot, state);
  float energy = 0;
  for (const KnotPass& pass : passes) {
    const std::array<Eigen::Vector3f, 5> x = chain_points(knot, axes, state.half_length, pass);
    std::array<Eigen::Vector3f, 4> unit;
    for (std::size_t i = 0; i < 4; ++i) {
      const Eigen::Vector3f edge = x[i + 1] - x[i];
      const float length = std::max(edge.norm(), 1e-6f);
      unit[i] = edge / length;
      const float stretch = length / std::max(pass.rest_length[i], 1e-6f) - 1;
      energy += weights.length * stretch * stretch;
    }
    for (std::size_t i = 0; i < 3; ++i) {
      const float bend = unit[i].dot(unit[i + 1]) - pass.rest_cosine[i];
      energy += weights.angle * bend * bend;
    }
  }
  return energy;
}

}  // namespace

KnotPoints knot_points(const KnotPlacement& knot, KnotState state, const KnotPass& pass) {
  const std::array<Eigen::Vector3f, 5> x =
      chain_points(knot, Directions(knot, state), state.half_length, pass);
  return {x[1], x[2], x[3]};
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
  return energy_only(knot, state, passes, weights);
}

KnotState relax_knot(const KnotPlacement& knot, KnotState state, std::span<const KnotPass> passes,
                     int iterations, KnotWeights weights) {
  if (passes.empty()) return state;
  const float shortest = 0.1f * knot.radius;
  Residuals residuals = evaluate(knot, state, passes, weights);
  for (int iteration = 0; iteration < iterations; ++iteration) {
    // A touch of damping keeps the 2x2 solve well posed when one parameter
    // barely moves the residuals (e.g. a straight, unstretched pass).
    Eigen::Matrix2f system = residuals.normal_matrix;
    system.diagonal().array() += 1e-6f + 1e-4f * system.trace();
    const Eigen::Vector2f step = system.ldlt().solve(-residuals.gradient);
    KnotState next{state.theta + step.x(), std::max(state.half_length + step.y(), shortest)};
    // Gauss-Newton may overshoot on these non-quadratic energies: halve the
    // step until the energy does not rise, or keep the state.
    bool lower = false;
    for (int halving = 0; halving < 3 && !lower; ++halving) {
      lower = energy_only(knot, next, passes, weights) <= residuals.energy;
      if (!lower)
        next = {0.5f * (state.theta + next.theta), 0.5f * (state.half_length + next.half_length)};
    }
    if (!lower) break;
    state = next;
    // Converged (a thousandth of a degree, a micrometre): the rest is noise.
    if (std::abs(step.x()) < 2e-5f && std::abs(step.y()) < 1e-3f * knot.radius) break;
    if (iteration + 1 < iterations) residuals = evaluate(knot, state, passes, weights);
  }
  return state;
}

}  // namespace psrig::preview
