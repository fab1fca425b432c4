// Knitted cloth in motion (issue 19): a hanging swatch comes to rest, its
// stretch under gravity grows with its length as a limp strip's should,
// energy never grows without input, nothing passes through a collider, a
// knit gives more across its courses than along its wales, and the same
// scene gives the same cloth on any number of threads.
#include "psrig/cloth/stitch_cloth.h"

#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "psrig/base/parallel.h"
#include "psrig/cloth/drape_scene.h"

namespace psrig::cloth {
namespace {

constexpr float kWale = 1.43f, kCourse = 1.11f;  // mm, the shipped jersey's
constexpr float kFrame = 1.0f / 60;

// A mesh of columns x rows stitches hanging in the x-z plane from z = 0:
// courses along x, wales down -z (turned: courses down -z).
StitchMesh hanging(int columns, int rows, bool courses_down = false) {
  StitchMesh mesh = make_stitch_mesh(columns, rows, kWale, kCourse, ClothShape::flat);
  float top = -1e9f;
  for (const Eigen::Vector3f& v : mesh.vertices) top = std::max(top, courses_down ? v.x() : v.y());
  for (Eigen::Vector3f& v : mesh.vertices)
    v = courses_down ? Eigen::Vector3f(v.y(), 0, v.x() - top) : Eigen::Vector3f(v.x(), 0, v.y() - top);
  return mesh;
}

// Pinned along its top edge, the row or column at z = 0.
StitchCloth hang(const StitchMesh& mesh, const KnitMaterial& material = {}) {
  StitchCloth cloth(mesh, material);
  for (int row = 0; row <= mesh.rows; ++row)
    for (int column = 0; column <= mesh.columns; ++column)
      if (std::abs(mesh.vertex(column, row).z()) < 1e-4f) cloth.pin(column, row);
  return cloth;
}

float lowest(const StitchCloth& cloth) {
  float low = 1e9f;
  for (const Eigen::Vector3f& v : cloth.mesh().vertices) low = std::min(low, v.z());
  return low;
}

void run(StitchCloth& cloth, float seconds) {
  for (int frame = 0; frame < static_cast<int>(seconds / kFrame); ++frame) cloth.step(kFrame);
}

TEST(StitchCloth, AHangingSwatchComesToRest) {
  StitchCloth cloth = hang(hanging(24, 30));
  // Started swinging: the whole swatch moving sideways.
  StitchMesh pushed = cloth.mesh();
  run(cloth, 0.1f);
  const double moving = cloth.energy().kinetic;
  EXPECT_GT(moving, 0);
  run(cloth, 6);
  const ClothEnergy rest = cloth.energy();
  // At rest: moving with less than a millionth of the energy the fall gave it.
  EXPECT_LT(rest.kinetic, 1e-3 * moving);
  const float mean_speed = [&] {
    double sum = 0;
    for (const Eigen::Vector3f& v : cloth.velocities()) sum += v.norm();
    return static_cast<float>(sum / static_cast<double>(cloth.velocities().size()));
  }();
  EXPECT_LT(mean_speed, 0.1f);  // mm/s
}

// A limp strip hanging under its own weight: tension grows linearly up
// from its free end, so within the balance interval (a linear spring) its
// stretch grows with the square of its length.
TEST(StitchCloth, StretchUnderGravityGrowsWithTheSquareOfTheLength) {
  const auto elongation = [](int rows) {
    StitchCloth cloth = hang(hanging(6, rows));
    run(cloth, 8);
    return -lowest(cloth) - static_cast<float>(rows) * kCourse;
  };
  const float short_strip = elongation(20), long_strip = elongation(40);
  EXPECT_GT(short_strip, 0);
  EXPECT_NEAR(long_strip / short_strip, 4.0, 0.6);
}

TEST(StitchCloth, AKnitGivesMoreAcrossItsCoursesThanAlongItsWales) {
  const auto elongation = [](bool courses_down) {
    StitchCloth cloth = hang(hanging(courses_down ? 30 : 6, courses_down ? 6 : 30, courses_down));
    run(cloth, 8);
    const float length = courses_down ? 30 * kWale : 30 * kCourse;
    return (-lowest(cloth) - length) / length;
  };
  const float across = elongation(true), along = elongation(false);
  EXPECT_GT(across, 2.0f * along) << across << " vs " << along;
}

TEST(StitchCloth, EnergyNeverGrowsWithoutInput) {
  // Released sideways (turned 40 degrees about the pinned edge) it swings
  // and settles; no frame's energy (motion, height, springs) is above the
  // frame's before, to a thousandth of what the swing gives away in all.
  StitchMesh mesh = hanging(16, 20);
  const float turn = 0.7f;
  for (Eigen::Vector3f& v : mesh.vertices)
    v = {v.x(), -std::sin(turn) * v.z(), std::cos(turn) * v.z()};
  StitchCloth cloth = hang(mesh);
  std::vector<double> energy{cloth.energy().total()};
  for (int frame = 0; frame < 240; ++frame) {
    cloth.step(kFrame);
    energy.push_back(cloth.energy().total());
  }
  const double released = energy.front() - energy.back();
  EXPECT_GT(released, 0);
  for (std::size_t frame = 1; frame < energy.size(); ++frame)
    EXPECT_LE(energy[frame] - energy[frame - 1], 1e-3 * released) << "frame " << frame;
}

TEST(StitchCloth, NothingPassesThroughACollider) {
  const std::vector<Collider> colliders{
      PlaneCollider{{0, 0, -40}, {0, 0, 1}},
      SphereCollider{{0, 0, -20}, 12},
      CapsuleCollider{{-30, 0, -18}, {30, 0, -18}, 5},
      BoxCollider{{-40, -40, -60}, {40, 3, -15}},  // a table whose edge runs along x
  };
  for (const Collider& collider : colliders) {
    // A swatch held flat above it and dropped.
    StitchMesh mesh = make_stitch_mesh(24, 24, kWale, kCourse, ClothShape::flat);
    StitchCloth cloth(mesh, {});
    cloth.colliders = {collider};
    float deepest = 0;
    for (int frame = 0; frame < 150; ++frame) {
      cloth.step(kFrame);
      deepest = std::max(deepest, cloth.deepest_penetration());
    }
    EXPECT_LT(deepest, 0.05f) << collider.index();
    // And it did reach the collider: it lies on it, not in the air.
    EXPECT_LT(cloth.energy().kinetic, 1e3) << collider.index();
  }
}

TEST(StitchCloth, TheSameSceneOnAnyNumberOfThreads) {
  const auto simulate = [](int threads) {
    psrig::set_thread_count(threads);
    StitchMesh mesh = make_stitch_mesh(32, 32, kWale, kCourse, ClothShape::flat);
    StitchCloth cloth(mesh, {});
    cloth.colliders = {SphereCollider{{0, 0, -15}, 10}};
    run(cloth, 0.5f);
    return cloth.mesh().vertices;
  };
  const auto one = simulate(1), two = simulate(2), many = simulate(0);
  psrig::set_thread_count(0);
  ASSERT_EQ(one.size(), two.size());
  for (std::size_t i = 0; i < one.size(); ++i) {
    EXPECT_EQ(one[i], two[i]) << i;
    EXPECT_EQ(one[i], many[i]) << i;
  }
}

// The drape scenes' yarns, not only the cloth's masses, come out the same
// whatever the thread count.
TEST(DrapeScene, TheSameYarnsOnAnyNumberOfThreads) {
  const auto chart = load_stitch_chart(std::filesystem::path(PSRIG_SOURCE_DIR) /
                                       "config/patterns/stockinette.chart");
  ASSERT_TRUE(chart);
  const auto yarns_with = [&](int threads) {
    psrig::set_thread_count(threads);
    auto fabric = KnitFabric::build(*chart, 16, 18, {});
    EXPECT_TRUE(fabric);
    DrapeAnimation scene(std::move(*fabric), DrapeScene::sphere);
    for (int frame = 0; frame < 12; ++frame)
      scene.advance(kFrame);
    YarnSet yarns;
    scene.yarns(yarns);
    return yarns;
  };
  const YarnSet one = yarns_with(1), two = yarns_with(2);
  psrig::set_thread_count(0);
  ASSERT_EQ(one.curves.size(), two.curves.size());
  for (std::size_t c = 0; c < one.curves.size(); ++c) EXPECT_EQ(one.curves[c].points, two.curves[c].points) << c;
  // And the ball is under the cloth, which lies on it.
  EXPECT_LT(one.bounds().max().y(), 5.0f);
}

}  // namespace
}  // namespace psrig::cloth
