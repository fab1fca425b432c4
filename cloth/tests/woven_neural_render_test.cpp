// The neural woven BSDF's picture against the 256-sample ground truth
// (chen2024 6, issue 31): with the shipped weights (config/woven/woven.wnn),
// on the shipped plain, 2/2 twill and satin and on two weaves the network
// never saw (3/1 twill, 2/2 basket), its MSE against the ground truth beside
// the one-sample render's and an equal-time render's (the reference
// estimator at as many samples as fit in the neural render's time).
// PSRIG_WOVEN_NEURAL_DIR=dir writes ground truth | neural | 1 spp |
// equal time side by side there as PNG.

#include "psrig/cloth/woven_neural_render.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <set>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "psrig/cloth/srgb.h"
#include "psrig/cloth/weave_rules.h"
#include "psrig/cloth/woven_dataset_generator.h"
#include "psrig/formats/image_io.h"
#include "test_support.h"

namespace psrig::cloth {
namespace {

const std::filesystem::path kShippedWeights = PSRIG_SOURCE_DIR "/config/woven/woven.wnn";

TEST(WovenNeuralRender, FootprintLookupWrapsTheCentreAndTakesTheSquareOfTheSameArea) {
  Footprint footprint;
  footprint.centre = {-1, 9};  // spacings
  footprint.edge_u = {2, 0};   // a 2 x 8 spacing rectangle on a 4 x 4 repeat:
  footprint.edge_v = {0, 8};   // 0.5 x 2 repeats, the area of a 1 x 1 square
  const WovenLookup lookup = footprint_lookup(footprint, {4, 4});
  EXPECT_FLOAT_EQ(lookup.u, 0.75f);
  EXPECT_FLOAT_EQ(lookup.v, 0.25f);
  EXPECT_FLOAT_EQ(lookup.size, 1.0f);
}

Eigen::Vector3f light_towards(float tilt_deg, float turn_deg) {
  const float a = tilt_deg * std::numbers::pi_v<float> / 180;
  const float t = turn_deg * std::numbers::pi_v<float> / 180;
  return {std::sin(a) * std::cos(t), std::sin(a) * std::sin(t), std::cos(a)};
}

double image_mse(const WovenImage& a, const WovenImage& b) {
  double sum = 0;
  for (std::size_t i = 0; i < a.rgb.size(); ++i) {
    const double d = static_cast<double>(a.rgb[i]) - b.rgb[i];
    sum += d * d;
  }
  return sum / static_cast<double>(a.rgb.size());
}

template <class Render>
double seconds_to(Render&& render) {
  const auto start = std::chrono::steady_clock::now();
  render();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The pictures side by side, sRGB.
void write_side_by_side(const std::filesystem::path& file, const std::vector<WovenImage>& images) {
  const int w = images.front().width, h = images.front().height;
  cv::Mat bgr(h, w * static_cast<int>(images.size()), CV_8UC3, cv::Scalar(0, 0, 0));
  for (std::size_t n = 0; n < images.size(); ++n)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const Eigen::Vector3f c = images[n].at(x, y);
        for (int k = 0; k < 3; ++k)
          bgr.at<cv::Vec3b>(y, static_cast<int>(n) * w + x)[2 - k] = static_cast<unsigned char>(
              std::lround(255 * std::clamp(srgb_encode(c[k]), 0.0f, 1.0f)));
      }
  const auto written = formats::write_image(file, bgr);
  ASSERT_TRUE(written) << written.error().describe();
}

struct NeuralCase {
  std::string name;
  WeaveMatrix weave;
  bool seen;  // its family is among the training weaves
};

// A steep view (tilt 60 degrees), so that one 128 x 96 frame spans the
// scales: about a spacing a pixel at the bottom (2 to 5 pixels a repeat)
// to some 10 spacings a pixel along the view at the top (a fraction of a
// pixel a repeat). Material: Table 2's middle (psi 0, u 30, alpha 0.5,
// beta 1); the light 50 degrees from the normal, from the side.
TEST(WovenNeuralRender, MseAgainstTheGroundTruthBelowOneSampleAndEqualTime) {
  auto network = WovenNetwork::load(kShippedWeights);
  ASSERT_TRUE(network) << network.error().describe();
  std::vector<NeuralCase> cases;
  for (const char* file : {"plain.weave", "twill-2x2.weave", "satin-5.weave"}) {
    auto weave = load_weave_matrix(test::shipped_pattern(file));
    ASSERT_TRUE(weave);
    cases.push_back({std::filesystem::path(file).stem().string(), *weave, true});
  }
  cases.push_back({"twill-3x1 (unseen)", twill_weave(3, 1), false});
  cases.push_back({"basket-2x2 (unseen)", basket_weave(2), false});
  // Cases where the neural render does not beat a baseline, left out of
  // the assertions below and listed here (see cloth/README.md).
  const std::set<std::string> neural_loses_to_one_spp{};
  const std::set<std::string> neural_loses_to_equal_time{};

  const int width = 128, height = 96;
  WovenView view;
  view.distance = 250;
  view.tilt_deg = 60;
  view.azimuth_deg = -90;
  WovenLight light;
  light.direction = light_towards(50, 135);
  light.irradiance = 2.5f;
  WovenMaterialParameters parameters;
  parameters.alpha = 0.5f;
  parameters.beta = 1;
  const WovenShading shading{parameters.alpha, parameters.alpha, kDefaultDiffuseBlend};
  const char* dir = std::getenv("PSRIG_WOVEN_NEURAL_DIR");

  std::printf("%-20s %12s %12s %12s %4s %9s %9s\n", "weave", "MSE neural", "MSE 1 spp",
              "MSE eq.time", "spp", "t neural", "t 1 spp");
  for (const NeuralCase& c : cases) {
    SCOPED_TRACE(c.name);
    auto surface = WovenSurface::make(c.weave, parameters.shape, parameters.beta, parameters.beta);
    ASSERT_TRUE(surface);
    YarnColours colours;
    colours.warp_diffuse = c.weave.warp_colour.value_or(Eigen::Vector3f(0.55f, 0.12f, 0.1f));
    colours.weft_diffuse = c.weave.weft_colour.value_or(Eigen::Vector3f(0.75f, 0.7f, 0.6f));
    colours.warp_specular = colours.weft_specular = Eigen::Vector3f::Constant(0.3f);

    const WovenImage truth =
        render_woven_reference(*surface, shading, colours, view, light, width, height, 256, 1);
    // The neural render's time includes encoding the material: a pattern
    // or (alpha, beta) edit pays it once.
    WovenImage neural;
    const double neural_seconds = seconds_to([&] {
      auto sample = generate_woven_material(c.weave, parameters, 64);
      ASSERT_TRUE(sample);
      auto material = network->prepare(*sample);
      ASSERT_TRUE(material);
      neural = render_woven_neural(*network, *material, surface->repeat_size(), colours, view,
                                   light, width, height);
    });
    WovenImage one;
    const double one_seconds = seconds_to([&] {
      one = render_woven_reference(*surface, shading, colours, view, light, width, height, 1, 2);
    });
    // A sample's cost from a 4-sample render (one alone is too short to time).
    const double sample_seconds = seconds_to([&] {
                                    (void)render_woven_reference(*surface, shading, colours, view,
                                                                 light, width, height, 4, 3);
                                  }) /
                                  4;
    const int equal_spp = std::max(1, static_cast<int>(neural_seconds / sample_seconds));
    const WovenImage equal = render_woven_reference(*surface, shading, colours, view, light, width,
                                                    height, equal_spp, 4);

    const double mse_neural = image_mse(neural, truth), mse_one = image_mse(one, truth);
    const double mse_equal = image_mse(equal, truth);
    std::printf("%-20s %12.6f %12.6f %12.6f %4d %8.3fs %8.3fs\n", c.name.c_str(), mse_neural,
                mse_one, mse_equal, equal_spp, neural_seconds, one_seconds);
    if (!neural_loses_to_one_spp.contains(c.name)) {
      EXPECT_LT(mse_neural, mse_one);
    }
    if (!neural_loses_to_equal_time.contains(c.name)) {
      EXPECT_LT(mse_neural, mse_equal);
    }
    if (dir != nullptr) {
      std::filesystem::create_directories(dir);
      std::string stem = c.name.substr(0, c.name.find(' '));
      write_side_by_side(std::filesystem::path(dir) / ("neural-" + stem + ".png"),
                         {truth, neural, one, equal});
    }
  }
}

}  // namespace
}  // namespace psrig::cloth
