// The simulated rig's LEDs: their switch history answers how much each
// shone over an exposure, and a configuration finds its rig's LEDs.

#include "psrig/sim/simulated_leds.h"

#include <chrono>

#include <gtest/gtest.h>

namespace psrig::lights {
namespace {

using namespace std::chrono_literals;

TEST(SimulatedLeds, ExposureWeightsFollowTheSwitches) {
  sim::SimulatedLeds leds(3);
  const auto t0 = Clock::now();
  leds.set_led(1, true, 1.0, t0 + 10ms);
  leds.all_off(t0 + 20ms);
  leds.set_led(2, true, 0.5, t0 + 20ms);
  const auto w = leds.exposure_weights(t0, t0 + 40ms);
  EXPECT_NEAR(w[0], 0.0, 1e-9);
  EXPECT_NEAR(w[1], 0.25, 1e-6);  // on for 10 of 40 ms
  EXPECT_NEAR(w[2], 0.25, 1e-6);  // on at half level for 20 of 40 ms
  EXPECT_EQ(leds.leds_on(), std::vector<int>{2});
  const auto later = leds.exposure_weights(t0 + 30ms, t0 + 40ms);
  EXPECT_NEAR(later[2], 0.5, 1e-6);
  EXPECT_FALSE(leds.log().overlap());
}

TEST(SimulatedLeds, LongRunsDoNotGrowTheHistory) {
  sim::SimulatedLeds leds(3);
  auto t = Clock::now();
  for (int i = 0; i < 20000; ++i) {
    leds.set_led(i % 3, true, 1.0, t);
    t += 1ms;
    leds.all_off(t);
    t += 1ms;
  }
  leds.set_led(1, true, 1.0, t);
  // The state survives the folding of old history.
  EXPECT_EQ(leds.leds_on(), std::vector<int>{1});
  EXPECT_NEAR(leds.exposure_weights(t, t + 10ms)[1], 1.0, 1e-6);
}

TEST(SimulatedLeds, AttachFindsTheRigsLedsThroughTheConfiguration) {
  config::RigConfig config;
  auto leds = sim::SimulatedLeds::attach(config);
  ASSERT_EQ(leds->channel_count(), 3);
  EXPECT_EQ(sim::SimulatedLeds::attach(config), leds);
  // What the sim lights switch, any other holder of the rig sees.
  sim::SimulatedLeds::attach(config)->set_led(1, true);
  EXPECT_EQ(leds->leds_on(), std::vector<int>{1});

  config::RigConfig other = config;
  other.lights.intensity = {0.5, 0.5, 0.5};  // not what makes the rig
  EXPECT_EQ(sim::SimulatedLeds::attach(other), leds);
  other.geometry.slant_deg = 30;
  EXPECT_NE(sim::SimulatedLeds::attach(other), leds);
  other = config;
  other.lights.channels = 4;
  EXPECT_EQ(sim::SimulatedLeds::attach(other)->channel_count(), 4);

  // Released by every holder: the next one starts dark.
  leds.reset();
  EXPECT_TRUE(sim::SimulatedLeds::attach(config)->leds_on().empty());
}

}  // namespace
}  // namespace psrig::lights
