#pragma once
// The camera rig.toml names, opened as psrig opens it and started; null
// (with the test failed) when either step fails.

#include <memory>

#include <gtest/gtest.h>

#include "psrig/cameras/camera.h"
#include "psrig/rig/open_devices.h"

namespace psrig::test {

inline std::unique_ptr<cameras::Camera> open_started(const config::RigConfig& rig) {
  auto camera = rig::open_camera(rig);
  EXPECT_TRUE(camera.has_value()) << (camera ? "" : camera.error().describe());
  if (!camera) return nullptr;
  auto started = (*camera)->start();
  EXPECT_TRUE(started.has_value()) << (started ? "" : started.error().describe());
  return std::move(*camera);
}

}  // namespace psrig::test
