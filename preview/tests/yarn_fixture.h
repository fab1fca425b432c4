#pragma once
// Small yarn sets with known geometry for the yarn renderer's tests, built
// in memory: straight yarns, two yarns crossing, a grid of wavy yarns, a
// plain weave.

#include <cmath>
#include <numbers>

#include "psrig/cloth/yarn_curves.h"

namespace psrig::preview::testing {

// A straight yarn along x through (0, y, z), `length` mm long, with
// `lift(t)` for t from 0 to 1 along it.
template <class Lift>
cloth::YarnCurve straight_yarn_lifted(float length, int points, float y, float z, Lift lift,
                               const Eigen::Vector3f& colour) {
  cloth::YarnCurve curve;
  for (int i = 0; i < points; ++i) {
    const float t = static_cast<float>(i) / static_cast<float>(points - 1);
    curve.points.emplace_back((t - 0.5f) * length, y, z);
    curve.normals.push_back(Eigen::Vector3f::UnitZ());
    curve.lift.push_back(lift(t));
    curve.colours.push_back(colour);
  }
  return curve;
}

inline cloth::YarnCurve straight_yarn(float length, int points, float y = 0, float z = 0, float lift = 1,
                               const Eigen::Vector3f& colour = {0.55f, 0.18f, 0.12f}) {
  return straight_yarn_lifted(
      length, points, y, z, [lift](float) { return lift; }, colour);
}

// The same yarn turned a quarter about z: along y through (x, 0, z).
inline cloth::YarnCurve along_y(cloth::YarnCurve curve, float x) {
  for (Eigen::Vector3f& point : curve.points)
    point = {x, point.x(), point.z()};
  return curve;
}

// Two yarns touching where they cross at the origin: `under` along x at
// z = -radius behind, `over` along y at z = +radius in front.
inline cloth::YarnSet crossing_yarns(float radius, float length, const Eigen::Vector3f& under_colour,
                              const Eigen::Vector3f& over_colour) {
  cloth::YarnSet set;
  set.style.radius_mm = radius;
  set.curves.push_back(straight_yarn(length, 161, 0, -radius, -1, under_colour));
  set.curves.push_back(along_y(straight_yarn(length, 161, 0, radius, 1, over_colour), 0));
  return set;
}

// `rows` yarns along x, `spacing` apart in y, waving in z over and under
// (alternate rows in opposite phase), about `points_per_mm` points a mm.
inline cloth::YarnSet wavy_grid(int rows, float length, float spacing, float radius,
                         float points_per_mm = 4) {
  cloth::YarnSet set;
  set.style.radius_mm = radius;
  const int points = static_cast<int>(length * points_per_mm) + 1;
  const float wave = 2 * std::numbers::pi_v<float> / (2 * spacing);
  for (int row = 0; row < rows; ++row) {
    cloth::YarnCurve curve;
    const float y = (static_cast<float>(row) - static_cast<float>(rows - 1) / 2) * spacing;
    const float phase = row % 2 == 0 ? 0.0f : std::numbers::pi_v<float>;
    for (int i = 0; i < points; ++i) {
      const float x = (static_cast<float>(i) / static_cast<float>(points - 1) - 0.5f) * length;
      const float lift = std::sin(wave * x + phase);
      curve.points.emplace_back(x, y, radius * lift);
      curve.normals.push_back(Eigen::Vector3f::UnitZ());
      curve.lift.push_back(lift);
    }
    set.curves.push_back(std::move(curve));
  }
  return set;
}

// A plain weave of `threads` warps (along y) and as many wefts (along x),
// `spacing` mm apart, each passing over one and under the next: a dense,
// exactly periodic cloth, the worst case for aliasing far away.
inline cloth::YarnSet plain_weave(int threads, float spacing, float radius, float flatness,
                                  float points_per_mm = 5) {
  cloth::YarnSet set;
  set.style.radius_mm = radius;
  set.style.flatness = flatness;
  set.style.colour = {0.62f, 0.52f, 0.38f};
  const float length = static_cast<float>(threads) * spacing;
  const int points = static_cast<int>(length * points_per_mm) + 1;
  const float wave = std::numbers::pi_v<float> / spacing;
  for (int direction = 0; direction < 2; ++direction)
    for (int thread = 0; thread < threads; ++thread) {
      cloth::YarnCurve curve;
      const float offset = (static_cast<float>(thread) - static_cast<float>(threads - 1) / 2) * spacing;
      const float phase = (thread % 2 == 0 ? 0.0f : std::numbers::pi_v<float>) +
                          (direction == 0 ? 0.0f : std::numbers::pi_v<float>);
      for (int i = 0; i < points; ++i) {
        const float along = (static_cast<float>(i) / static_cast<float>(points - 1) - 0.5f) * length;
        const float lift = std::sin(wave * along + phase);
        const float z = flatness * radius * lift;
        curve.points.push_back(direction == 0 ? Eigen::Vector3f(along, offset, z)
                                              : Eigen::Vector3f(offset, along, z));
        curve.normals.push_back(Eigen::Vector3f::UnitZ());
        curve.lift.push_back(lift);
        curve.colours.push_back(direction == 0 ? Eigen::Vector3f(0.62f, 0.52f, 0.38f)
                                               : Eigen::Vector3f(0.30f, 0.36f, 0.55f));
      }
      set.curves.push_back(std::move(curve));
    }
  return set;
}

}  // namespace psrig::preview::testing
