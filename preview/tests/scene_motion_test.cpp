// The kiosk's motion: the light orbits at its rate, a kick spins the model
// up and the spin brakes away, and any frame's pose follows from its time.

#include "psrig/preview/scene_motion.h"

#include <gtest/gtest.h>

namespace psrig::preview {
namespace {

TEST(SceneMotion, LightOrbitsAtItsRate) {
  const SceneMotion motion({.light_orbit_deg_per_s = 36});
  SceneView base;
  base.light.tilt_deg = 10;
  EXPECT_NEAR(motion.at(0, base).light.tilt_deg, 10, 1e-9);
  EXPECT_NEAR(motion.at(2.5, base).light.tilt_deg, 100, 1e-9);
  EXPECT_NEAR(motion.at(10, base).light.tilt_deg, 10, 1e-9);  // a full turn
}

TEST(SceneMotion, KickSpinsUpThenBrakes) {
  SceneMotion motion({.sway_amplitude_deg = 0, .brake_per_s = 1.0});
  motion.kick(1.0, 90);
  EXPECT_NEAR(motion.spin(1.0), 90, 1e-9);
  EXPECT_NEAR(motion.spin(2.0), 90 * std::exp(-1.0), 1e-9);
  EXPECT_LT(motion.spin(15.0), 0.01);
  // It has turned, in all, speed / brake: 90 degrees.
  EXPECT_NEAR(motion.at(30, {}).model_yaw_deg, 90, 1e-6);
  EXPECT_NEAR(motion.at(1.0, {}).model_yaw_deg, 0, 1e-9);
  // A second kick while spinning adds to what is left: in all the two
  // kicks turn the model 90 + 90 degrees.
  motion.kick(2.0, 90);
  EXPECT_NEAR(motion.spin(2.0), 90 + 90 * std::exp(-1.0), 1e-9);
  EXPECT_NEAR(motion.at(2.0, {}).model_yaw_deg, 90 * (1 - std::exp(-1.0)), 1e-9);
  EXPECT_NEAR(motion.at(40, {}).model_yaw_deg, 180, 1e-6);
}

TEST(SceneMotion, SwayStaysWithinItsAmplitude) {
  const SceneMotion motion({.sway_amplitude_deg = 20, .sway_period_s = 16});
  double most = 0;
  for (double t = 0; t < 32; t += 0.1)
    most = std::max(most, std::abs(motion.at(t, {}).model_yaw_deg));
  EXPECT_LE(most, 20 + 1e-9);
  EXPECT_GT(most, 19.5);
}

}  // namespace
}  // namespace psrig::preview
