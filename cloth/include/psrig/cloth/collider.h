#pragma once
// What simulated cloth can lie on or hang against: a plane (the floor), a
// sphere, a capsule (an arm) and a box (a table, with its edge). Each gives
// the signed distance from a point to its surface and the surface's normal
// there; cloth is kept outside by its own half-thickness.
// Millimetres; any orientation of the scene's choosing (+z up in the
// drape scenes).

#include <variant>

#include <Eigen/Core>

namespace psrig::cloth {

struct PlaneCollider {
  Eigen::Vector3f point{0, 0, 0};
  Eigen::Vector3f normal{0, 0, 1};  // unit, out of the solid side
};

struct SphereCollider {
  Eigen::Vector3f centre{0, 0, 0};
  float radius = 10;
};

// The points within `radius` of the segment from `a` to `b`.
struct CapsuleCollider {
  Eigen::Vector3f a{0, 0, 0}, b{1, 0, 0};
  float radius = 10;
};

// An axis-aligned box (a table top), its edges sharp.
struct BoxCollider {
  Eigen::Vector3f low{0, 0, 0}, high{1, 1, 1};
};

using Collider = std::variant<PlaneCollider, SphereCollider, CapsuleCollider, BoxCollider>;

struct SurfacePoint {
  float distance = 0;              // signed: negative inside
  Eigen::Vector3f normal{0, 0, 1};  // unit, the way out
};

[[nodiscard]] SurfacePoint nearest_surface(const Collider& collider, const Eigen::Vector3f& point);

}  // namespace psrig::cloth
