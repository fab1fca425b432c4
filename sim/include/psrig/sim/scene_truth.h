#pragma once
// The simulated world's answer for a scan of it: the swatch's true normals
// and heights, and its fabric's gauge as made (scan.json's
// ground_truth.fabric), against which processing and `psrig measure` are
// measured. The simulated camera adds it to every scan it takes; a test
// that shows the world to a real camera backend (the HIL tests' emulated
// V4L2 and libcamera devices) wraps that camera to add the same.

#include <memory>

#include "psrig/cameras/camera.h"
#include "psrig/formats/scan.h"

namespace psrig::sim {

class World;

// `rotation_deg`: the fabric turned counterclockwise on the rig ([sim]
// swatch_rotation_deg).
void add_scene_truth(const World& world, double rotation_deg, formats::Scan& scan);

// `camera` as it is, but its scans carry `world`'s answer.
[[nodiscard]] std::unique_ptr<cameras::Camera> with_scene_truth(
    std::unique_ptr<cameras::Camera> camera, std::shared_ptr<const World> world,
    double rotation_deg);

}  // namespace psrig::sim
