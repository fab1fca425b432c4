#include "psrig/cloth/bezier_patch.h"

#include <Eigen/Geometry>

namespace psrig::cloth {
namespace {

// Cubic Bernstein polynomials and their derivatives at t.
std::array<float, 4> bernstein(float t) {
  const float s = 1.0f - t;
  return {s * s * s, 3 * t * s * s, 3 * t * t * s, t * t * t};
}

std::array<float, 4> bernstein_derivative(float t) {
  const float s = 1.0f - t;
  return {-3 * s * s, 3 * s * s - 6 * t * s, 6 * t * s - 3 * t * t, 3 * t * t};
}

Eigen::Vector3f combine(const std::array<Eigen::Vector3f, 16>& control,
                        const std::array<float, 4>& along_u, const std::array<float, 4>& along_v) {
  Eigen::Vector3f sum = Eigen::Vector3f::Zero();
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i)
      sum += along_u[i] * along_v[j] * control[4 * j + i];
  return sum;
}

}  // namespace

BezierPatch BezierPatch::make(PatchShape shape, cv::Size2d extent) {
  const auto width = static_cast<float>(extent.width);
  const auto height = static_cast<float>(extent.height);
  // A flag: a wave across (z up and down along u) that grows toward the
  // free bottom edge, the sheet sagging toward the viewer there.
  constexpr std::array<float, 4> kWave = {0.0f, 0.16f, -0.16f, 0.06f};
  constexpr std::array<float, 4> kSpread = {1.0f, 0.8f, 0.6f, 0.4f};  // top row (v = 1) last
  std::array<Eigen::Vector3f, 16> control;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) {
      const float x = (static_cast<float>(i) / 3.0f - 0.5f) * width;
      const float y = (static_cast<float>(j) / 3.0f - 0.5f) * height;
      float z = 0;
      if (shape == PatchShape::draped)
        z = width * kWave[static_cast<std::size_t>(i)] * kSpread[static_cast<std::size_t>(j)] +
            0.08f * height * (1.0f - static_cast<float>(j) / 3.0f);
      control[static_cast<std::size_t>(4 * j + i)] = {x, y, z};
    }
  return BezierPatch(control);
}

Eigen::Vector3f BezierPatch::position(float u, float v) const {
  return combine(control_, bernstein(u), bernstein(v));
}

Eigen::Vector3f BezierPatch::d_du(float u, float v) const {
  return combine(control_, bernstein_derivative(u), bernstein(v));
}

Eigen::Vector3f BezierPatch::d_dv(float u, float v) const {
  return combine(control_, bernstein(u), bernstein_derivative(v));
}

PatchMesh tessellate(const BezierPatch& patch, int segments, cv::Size2d extent, cv::Size2d tile) {
  PatchMesh mesh;
  const auto n = static_cast<std::size_t>(segments + 1);
  mesh.vertices.reserve(n * n);
  const auto tiles_u = static_cast<float>(extent.width / tile.width);
  const auto tiles_v = static_cast<float>(extent.height / tile.height);
  for (int j = 0; j <= segments; ++j)
    for (int i = 0; i <= segments; ++i) {
      const float u = static_cast<float>(i) / static_cast<float>(segments);
      const float v = static_cast<float>(j) / static_cast<float>(segments);
      const Eigen::Vector3f position = patch.position(u, v);
      const Eigen::Vector3f along_u = patch.d_du(u, v);
      const Eigen::Vector3f normal = along_u.cross(patch.d_dv(u, v)).normalized();
      const Eigen::Vector3f tangent = along_u.normalized();
      const Eigen::Vector3f bitangent = normal.cross(tangent);
      PatchVertex vertex{};
      for (int c = 0; c < 3; ++c) {
        vertex.position[c] = position[c];
        vertex.normal[c] = normal[c];
        vertex.tangent[c] = tangent[c];
        vertex.bitangent[c] = bitangent[c];
      }
      // Centred so a tile's middle sits at the patch's middle.
      vertex.uv[0] = (u - 0.5f) * tiles_u + 0.5f;
      vertex.uv[1] = (v - 0.5f) * tiles_v + 0.5f;
      mesh.vertices.push_back(vertex);
    }
  for (int j = 0; j < segments; ++j)
    for (int i = 0; i < segments; ++i) {
      const auto corner = static_cast<std::uint32_t>(j * (segments + 1) + i);
      const auto above = corner + static_cast<std::uint32_t>(segments + 1);
      mesh.indices.insert(mesh.indices.end(),
                          {corner, corner + 1, above + 1, corner, above + 1, above});
    }
  return mesh;
}

}  // namespace psrig::cloth
