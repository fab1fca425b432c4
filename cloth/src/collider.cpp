#include "psrig/cloth/collider.h"

#include <algorithm>
#include <cmath>

namespace psrig::cloth {
namespace {

SurfacePoint from_centre(const Eigen::Vector3f& offset, float radius) {
  const float length = offset.norm();
  if (length < 1e-9f) return {-radius, {0, 0, 1}};
  return {length - radius, offset / length};
}

SurfacePoint surface_of(const PlaneCollider& plane, const Eigen::Vector3f& point) {
  return {(point - plane.point).dot(plane.normal), plane.normal};
}

SurfacePoint surface_of(const SphereCollider& sphere, const Eigen::Vector3f& point) {
  return from_centre(point - sphere.centre, sphere.radius);
}

SurfacePoint surface_of(const CapsuleCollider& capsule, const Eigen::Vector3f& point) {
  const Eigen::Vector3f axis = capsule.b - capsule.a;
  const float t = std::clamp((point - capsule.a).dot(axis) / std::max(axis.squaredNorm(), 1e-12f),
                             0.0f, 1.0f);
  return from_centre(point - (capsule.a + t * axis), capsule.radius);
}

SurfacePoint surface_of(const BoxCollider& box, const Eigen::Vector3f& point) {
  const Eigen::Vector3f centre = 0.5f * (box.low + box.high);
  const Eigen::Vector3f half = 0.5f * (box.high - box.low);
  const Eigen::Vector3f q = (point - centre).cwiseAbs() - half;
  if ((q.array() > 0).any()) {
    // Outside: to the nearest point of the box (a face, an edge or a corner).
    const Eigen::Vector3f nearest = point.cwiseMax(box.low).cwiseMin(box.high);
    const Eigen::Vector3f away = point - nearest;
    const float distance = away.norm();
    return {distance, away / std::max(distance, 1e-12f)};
  }
  // Inside: out through the nearest face.
  int axis = 0;
  for (int i = 1; i < 3; ++i)
    if (q[i] > q[axis]) axis = i;
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();
  normal[axis] = point[axis] > centre[axis] ? 1.0f : -1.0f;
  return {q[axis], normal};
}

}  // namespace

SurfacePoint nearest_surface(const Collider& collider, const Eigen::Vector3f& point) {
  return std::visit([&](const auto& shape) { return surface_of(shape, point); }, collider);
}

}  // namespace psrig::cloth
