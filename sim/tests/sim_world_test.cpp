// The simulated world and sensor: what the camera records is what the LEDs
// did during each exposure, with realistic noise; the world a configuration
// describes is the one the sim backends find.

#include <chrono>
#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include "psrig/sim/sensor.h"
#include "psrig/sim/simulated_leds.h"
#include "psrig/sim/world.h"
#include "shipped_swatch.h"
#include "test_support.h"

namespace psrig::sim {
namespace {

using namespace std::chrono_literals;

// Mean over every channel (the jersey is red: its blue is dark).
double brightness(const cv::Mat& m) {
  const cv::Scalar per_channel = cv::mean(m);
  return (per_channel[0] + per_channel[1] + per_channel[2]) / m.channels();
}

config::RigConfig small_world() {
  config::RigConfig c;
  c.sim.width = 64;
  c.sim.height = 48;
  return c;
}

TEST(SimWorld, RadianceIsTheRenderedSwatch) {
  const World world = test::made(World::make(small_world()));
  ASSERT_EQ(world.channel_count(), 3);
  EXPECT_EQ(world.radiance(0).size(), cv::Size(64, 48));
  EXPECT_NEAR(world.light_directions()[1][1], std::sin(2 * CV_PI / 3) * std::sqrt(0.5), 1e-9);
  EXPECT_GT(brightness(world.radiance(0)), 0.1);
}

TEST(SimWorld, NearLedsArePointSources) {
  config::RigConfig c;
  c.sim.width = 641;  // an odd size: the centre pixel sits on the axis
  c.sim.height = 481;
  c.sim.target = "white_card";
  c.sim.card_albedo = 0.6;
  c.sim.pixel_size_mm = 0.025;  // a 16 x 12 mm field
  c.geometry.led_distance_mm = 250;
  const World world = test::made(World::make(c));
  ASSERT_EQ(world.light_positions_mm().size(), 3U);
  EXPECT_NEAR(world.light_positions_mm()[0][0], 250 * std::sqrt(0.5), 1e-9);
  EXPECT_NEAR(world.light_directions()[0][2], std::sqrt(0.5), 1e-12);
  // At the field's centre as a distant LED in the same direction: albedo * cos 45°.
  const cv::Mat& r0 = world.radiance(0);
  EXPECT_NEAR(r0.at<cv::Vec3f>(240, 320)[1], 0.6 * std::sqrt(0.5), 1e-5);
  // Elsewhere n . (P - X) |P|² / |P - X|³ (LED 0 is to the image's right).
  for (const cv::Point px : {cv::Point(0, 0), cv::Point(640, 240), cv::Point(100, 400)}) {
    const cv::Vec3d p = world.light_positions_mm()[0];
    const cv::Vec3d x((px.x - 320) * 0.025, (240 - px.y) * 0.025, 0);
    const cv::Vec3d d = p - x;
    const double expected = 0.6 * d[2] * p.dot(p) / std::pow(cv::norm(d), 3);
    EXPECT_NEAR(r0.at<cv::Vec3f>(px)[0], expected, 1e-5) << px;
  }
  // Nearer the LED, brighter: the right edge against the left.
  EXPECT_GT(r0.at<cv::Vec3f>(240, 640)[0], r0.at<cv::Vec3f>(240, 0)[0] * 1.05);
  // Without positions: distant, uniform over the flat card.
  c.geometry.led_distance_mm.reset();
  const World distant = test::made(World::make(c));
  EXPECT_TRUE(distant.light_positions_mm().empty());
  EXPECT_NEAR(distant.radiance(0).at<cv::Vec3f>(0, 0)[0], 0.6 * std::sqrt(0.5), 1e-5);
  EXPECT_NEAR(distant.radiance(0).at<cv::Vec3f>(240, 640)[0], 0.6 * std::sqrt(0.5), 1e-5);
}

TEST(SimWorld, AttachFindsTheRigsWorldThroughTheConfiguration) {
  const config::RigConfig config = small_world();
  auto world = test::made(World::attach(config));
  // The sim camera and the sim lights, opened apart, meet in it.
  EXPECT_EQ(test::made(World::attach(config)), world);
  EXPECT_EQ(world->leds(), SimulatedLeds::attach(config));
  config::RigConfig other = config;
  other.sim.seed = 2;
  EXPECT_NE(test::made(World::attach(other)), world);
  other = config;
  other.camera.exposure_us = 5000;  // not what makes the world
  EXPECT_EQ(test::made(World::attach(other)), world);
  // Nobody holding it: the next rig opened gets a fresh world.
  const std::weak_ptr<World> held = world;
  const std::weak_ptr<SimulatedLeds> leds = world->leds();
  world.reset();
  EXPECT_TRUE(held.expired());
  EXPECT_TRUE(leds.expired());
}

// [sim] pattern: a shipped name (or an older alias) or a chart or weave file;
// the world keeps what its swatch is made of.
TEST(SimWorld, TheSwatchIsTheConfiguredPattern) {
  config::RigConfig c = small_world();
  const World jersey = test::made(World::make(c));
  ASSERT_TRUE(jersey.pattern());
  EXPECT_EQ(jersey.pattern()->name, "jersey");
  EXPECT_EQ(jersey.pattern()->file.filename(), "stockinette.chart");
  EXPECT_TRUE(jersey.pattern()->knitted());
  test::TempDir temp;
  std::ofstream(temp / "tabby.weave") << "colour warp #FF0000\n1 0\n0 1\n";
  c.sim.pattern = (temp / "tabby.weave").string();
  const World tabby = test::made(World::make(c));
  ASSERT_TRUE(tabby.pattern());
  EXPECT_FALSE(tabby.pattern()->knitted());
  EXPECT_EQ(tabby.pattern()->name, "tabby");
  // A red warp: the albedo's red is up where the warps lie.
  cv::Scalar mean = cv::mean(tabby.swatch().albedo);  // BGR
  EXPECT_GT(mean[2], 2 * mean[1]);
  // A calibration target has no pattern.
  c.sim.target = "white_card";
  EXPECT_FALSE(test::made(World::make(c)).pattern());
}

// A pattern that cannot be read is bad input naming sim.pattern and the
// file (the chart's own line and column for a mistake in it), from make()
// and attach() alike; nothing is registered, so a fixed file is read again.
TEST(SimWorld, ABadPatternIsBadInputNamingTheKeyAndFile) {
  config::RigConfig c = small_world();
  c.source = "/etc/psrig/rig.toml";
  c.sim.pattern = "argyle";
  const auto unknown = World::make(c);
  ASSERT_FALSE(unknown);
  EXPECT_EQ(unknown.error().kind, ErrorKind::bad_input);
  EXPECT_EQ(unknown.error().key, "sim.pattern");
  EXPECT_EQ(unknown.error().file, c.source);
  EXPECT_NE(unknown.error().message.find("stockinette"), std::string::npos)
      << unknown.error().describe();
  test::TempDir temp;
  const auto chart = temp / "broken.chart";
  std::ofstream(chart) << "K K\nK X\n";
  c.sim.pattern = chart.string();
  const auto broken = World::attach(c);
  ASSERT_FALSE(broken);
  EXPECT_EQ(broken.error().kind, ErrorKind::bad_input);
  EXPECT_EQ(broken.error().file, chart);
  EXPECT_EQ(broken.error().line, 2);
  std::ofstream(chart) << "K K\nK P\n";
  EXPECT_TRUE(World::attach(c));
}

class SimSensorTest : public ::testing::Test {
 protected:
  config::RigConfig config_ = small_world();
  World world_ = test::made(World::make(config_));
  Sensor sensor_{config_.sim, 7};
};

TEST_F(SimSensorTest, DarkFrameSitsAtTheBlackLevel) {
  const cv::Mat dark = sensor_.expose(world_, Clock::now(), {}, 1);
  EXPECT_EQ(dark.type(), CV_16UC3);
  const double mean = brightness(dark);
  EXPECT_GT(mean, config_.sim.black_level);       // plus a little room light
  EXPECT_LT(mean, config_.sim.black_level + 40);  // but not much
  double top = 0;
  cv::minMaxLoc(dark.reshape(1), nullptr, &top);
  EXPECT_LE(top, sensor_.white_level());
}

TEST_F(SimSensorTest, AnLedOnForTheExposureBrightensTheFrame) {
  const auto t0 = Clock::now();
  world_.leds()->set_led(0, true, 1.0, t0 - 1s);
  const cv::Mat lit = sensor_.expose(world_, t0, {}, 2);
  world_.leds()->all_off(t0 + 1s);
  const cv::Mat dark = sensor_.expose(world_, t0 + 2s, {}, 3);
  EXPECT_GT(brightness(lit), brightness(dark) + 300);
  // Half the exposure under the LED: about half the signal above black.
  world_.leds()->set_led(0, true, 1.0, t0 + 3s + 10ms);
  const cv::Mat half = sensor_.expose(world_, t0 + 3s, {}, 4);
  const double black = brightness(dark);
  EXPECT_NEAR((brightness(half) - black) / (brightness(lit) - black), 0.5, 0.05);
}

TEST_F(SimSensorTest, ShotNoiseGrowsWithTheSignal) {
  // Two frames of the same light: their difference is noise only. Its
  // variance in electrons must match the mean signal (Poisson) plus read noise.
  const auto t0 = Clock::now();
  world_.leds()->set_led(1, true, 1.0, t0 - 1s);
  const cv::Mat a = sensor_.expose(world_, t0, {}, 10), b = sensor_.expose(world_, t0, {}, 11);
  cv::Mat a_f, b_f;
  a.convertTo(a_f, CV_64F);
  b.convertTo(b_f, CV_64F);
  const double black = config_.sim.black_level, white = sensor_.white_level();
  const double electrons_per_code = config_.sim.full_well / (white - black);
  const double mean_electrons = (cv::mean(a_f)[0] - black) * electrons_per_code;
  cv::Scalar mean, deviation;
  cv::meanStdDev(a_f - b_f, mean, deviation);
  const double noise_electrons = deviation[0] / std::sqrt(2.0) * electrons_per_code;
  const double expected =
      std::sqrt(mean_electrons + config_.sim.read_noise * config_.sim.read_noise);
  EXPECT_NEAR(noise_electrons / expected, 1.0, 0.15);
}

TEST_F(SimSensorTest, SameFrameNumberSameFrame) {
  const auto t0 = Clock::now();
  world_.leds()->set_led(2, true, 1.0, t0 - 1s);
  EXPECT_EQ(
      cv::norm(sensor_.expose(world_, t0, {}, 5), sensor_.expose(world_, t0, {}, 5), cv::NORM_INF),
      0);
  EXPECT_GT(
      cv::norm(sensor_.expose(world_, t0, {}, 5), sensor_.expose(world_, t0, {}, 6), cv::NORM_INF),
      0);
}

TEST_F(SimSensorTest, ExposureAndGainScaleTheSignalAndVignettingDarkensCorners) {
  const auto t0 = Clock::now();
  world_.leds()->set_led(0, true, 1.0, t0 - 1s);
  SensorSettings base;
  SensorSettings longer = base;
  longer.exposure_us *= 2;
  SensorSettings grey = base;
  grey.channels = 1;
  const double black = config_.sim.black_level;
  config::SimConfig dim = config_.sim;  // so that twice the exposure does not clip
  dim.led_irradiance = 0.5;
  const Sensor dim_sensor(dim, 3);
  const double one = brightness(dim_sensor.expose(world_, t0, base, 1)) - black;
  const double two = brightness(dim_sensor.expose(world_, t0, longer, 2)) - black;
  EXPECT_NEAR(two / one, 2.0, 0.1);
  EXPECT_EQ(sensor_.expose(world_, t0, grey, 3).type(), CV_16UC1);
  // A flat white card shows the fall-off alone: the corners against the
  // centre, over many pixels.
  config::RigConfig strong = small_world();
  strong.sim.vignetting = 0.5;
  strong.sim.target = "white_card";
  const World card = test::made(World::make(strong));
  card.leds()->set_led(0, true, 1.0, t0 - 1s);
  Sensor vignetted(strong.sim, 1);
  const cv::Mat frame = vignetted.expose(card, t0, base, 9);
  const double centre = brightness(frame(cv::Rect(24, 16, 16, 16)));
  const double corner = brightness(frame(cv::Rect(0, 0, 8, 8)));
  EXPECT_LT(corner - black, 0.8 * (centre - black));
}

}  // namespace
}  // namespace psrig::sim
