#include "psrig/cloth/drape_scene.h"

#include <array>
#include <cmath>
#include <numbers>
#include <utility>

namespace psrig::cloth {
namespace {

constexpr float kStepsPerSecond = 120;

constexpr std::array<std::pair<std::string_view, DrapeScene>, 4> kNames{{
    {"hang", DrapeScene::hang},
    {"table", DrapeScene::table},
    {"sphere", DrapeScene::sphere},
    {"arm", DrapeScene::arm},
}};

// The cloth's size, for placing things against it.
struct Extent {
  float width = 0, height = 0;
};
Extent extent_of(const StitchMesh& mesh) {
  return {mesh.face_width_mm * static_cast<float>(mesh.columns),
          mesh.face_height_mm * static_cast<float>(mesh.rows)};
}

// The flat rest mesh (centred on the origin in x-y, front +z) laid into
// the scene, +y up.
StitchMesh laid(StitchMesh mesh, DrapeScene scene) {
  const Extent size = extent_of(mesh);
  for (Eigen::Vector3f& v : mesh.vertices) {
    switch (scene) {
      case DrapeScene::hang: {
        // Hanging from its top course, turned 25 degrees out of the
        // vertical so that it swings before it settles.
        const float down = v.y() - 0.5f * size.height;  // 0 at the top, negative below
        const float turn = 25 * std::numbers::pi_v<float> / 180;
        v = {v.x(), std::cos(turn) * down, -std::sin(turn) * down};
        break;
      }
      case DrapeScene::table:
        // Lying flat (front up) above the table, a quarter of it over the
        // edge at z = 0: the table's friction holds the rest.
        v = {v.x(), 8, -v.y() + (0.25f - 0.5f) * size.height};
        break;
      case DrapeScene::sphere:
      case DrapeScene::arm:
        v = {v.x(), 4, -v.y()};
        break;
    }
  }
  return mesh;
}

float largest(const Extent& e) { return std::max(e.width, e.height); }

}  // namespace

std::optional<DrapeScene> parse_drape_scene(std::string_view name) {
  for (const auto& [n, s] : kNames)
    if (n == name) return s;
  return std::nullopt;
}

std::string_view to_string(DrapeScene scene) {
  for (const auto& [n, s] : kNames)
    if (s == scene) return n;
  return "unknown";
}

DrapeAnimation::DrapeAnimation(KnitFabric fabric, DrapeScene scene, KnitMaterial material)
    : fabric_(std::move(fabric)),
      scene_(scene),
      cloth_(laid(fabric_.mesh(), scene), material, Eigen::Vector3f(0, -9810, 0)) {
  const StitchMesh& mesh = cloth_.mesh();
  const float l = largest(extent_of(mesh));
  switch (scene) {
    case DrapeScene::hang: {
      for (int column = 0; column <= mesh.columns; ++column) cloth_.pin(column, mesh.rows);
      // The rail it hangs from, 6 mm across, its underside on the top
      // course: drawn with the cloth, and met by it if it swings back.
      constexpr float rail = 3;
      const float above = rail + 0.5f * material.thickness_mm;
      cloth_.colliders = {CapsuleCollider{{-0.65f * l, above, 0}, {0.65f * l, above, 0}, rail}};
      break;
    }
    case DrapeScene::table:
      // Its top at y = 0, its edge along x at z = 0.
      cloth_.colliders = {BoxCollider{{-l, -l, -2 * l}, {l, 0, 0}},
                          PlaneCollider{{0, -l, 0}, {0, 1, 0}}};
      break;
    case DrapeScene::sphere:
      // A ball 0.4 of the swatch across, so that the swatch covers it and
      // hangs in folds to the floor (at 0.6, the share Cusick's drape test
      // gives its disc, little was left beyond the ball to hang).
      cloth_.colliders = {SphereCollider{{0, -0.2f * l, 0}, 0.2f * l},
                          PlaneCollider{{0, -0.6f * l, 0}, {0, 1, 0}}};
      break;
    case DrapeScene::arm:
      // A forearm, about 4 cm across, running under the cloth's middle.
      cloth_.colliders = {CapsuleCollider{{-0.8f * l, -20, 0}, {0.8f * l, -20, 0}, 20},
                          PlaneCollider{{0, -1.2f * l, 0}, {0, 1, 0}}};
      break;
  }
}

void DrapeAnimation::advance(float dt) {
  // The cloth is stepped at 120 Hz or faster whatever the frame rate: a
  // frame's fall must stay small beside the yarn and the colliders.
  const int substeps = std::max(1, static_cast<int>(std::ceil(dt * kStepsPerSecond - 1e-3f)));
  for (int i = 0; i < substeps; ++i) step(dt / static_cast<float>(substeps));
}

void DrapeAnimation::step(float dt) {
  if (scene_ == DrapeScene::arm && time_ > 1.5) {
    // After the cloth has settled over it, the arm rises and falls, 15 mm
    // once a second.
    const auto height = static_cast<float>(15 * std::sin(2 * std::numbers::pi * (time_ - 1.5)));
    auto& arm = std::get<CapsuleCollider>(cloth_.colliders.front());
    arm.a.y() += height - arm_height_;
    arm.b.y() += height - arm_height_;
    arm_height_ = height;
    cloth_.note_input();
  }
  cloth_.step(dt);
  time_ += dt;
}

}  // namespace psrig::cloth
