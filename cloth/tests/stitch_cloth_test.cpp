// Knitted cloth in motion (issue 19): a hanging swatch comes to rest, its
// stretch under gravity grows with its length as a limp strip's should,
// energy never grows without input, nothing passes through a collider, a
// knit gives more across its courses than along its wales, and the same
// scene gives the same cloth on any number of threads.
#include "psrig/cloth/stitch_cloth.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>

#include <gtest/gtest.h>

#include "drape_shadow.h"
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

// Peirce's cantilever (ASTM D1388): a strip held flat, its end over the
// edge, droops until the chord from the edge to its tip is theta below the
// horizontal; its bending length is c = l (cos(theta/2) / (8 tan theta))^(1/3)
// for an overhang l, and c = (B/W)^(1/3) for a rigidity B and a weight W
// per area. The simulated cloth's c is the material's, along either axis.
float peirce_bending_length(bool along_courses, int overhang, const KnitMaterial& material) {
  const int clamped = 3, across = 4;
  const int columns = along_courses ? clamped + overhang : across;
  const int rows = along_courses ? across : clamped + overhang;
  StitchMesh mesh = make_stitch_mesh(columns, rows, kWale, kCourse, ClothShape::flat);
  StitchCloth cloth(mesh, material);
  const Eigen::Vector3f origin = mesh.vertex(0, 0);
  const auto along = [&](const Eigen::Vector3f& v) {
    return along_courses ? v.x() - origin.x() : v.y() - origin.y();
  };
  const float edge = static_cast<float>(clamped) * (along_courses ? kWale : kCourse);
  for (int row = 0; row <= rows; ++row)
    for (int column = 0; column <= columns; ++column)
      if (along(mesh.vertex(column, row)) <= edge + 1e-4f) cloth.pin(column, row);
  run(cloth, 6);
  Eigen::Vector3f tip = Eigen::Vector3f::Zero();
  const int ends = across + 1;
  for (int k = 0; k <= across; ++k)
    tip += along_courses ? cloth.mesh().vertex(columns, k) : cloth.mesh().vertex(k, rows);
  tip /= static_cast<float>(ends);
  const float drop = origin.z() - tip.z(), reach = along(tip) - edge;
  const float theta = std::atan2(drop, reach);
  const float l = static_cast<float>(overhang) * (along_courses ? kWale : kCourse);
  return l * std::cbrt(std::cos(theta / 2) / (8 * std::tan(theta)));
}

TEST(StitchCloth, BendsAsPeircesCantileverSays) {
  const KnitMaterial material;
  const float weight = material.areal_density_g_per_m2 * 1e-3f * 9.81f;  // N/m^2
  const auto expected = [&](float rigidity_un_m) {
    return 1e3f * std::cbrt(rigidity_un_m * 1e-6f / weight);  // mm
  };
  const float course = expected(material.course_bending_un_m);
  const float wale = expected(material.wale_bending_un_m);
  // Overhangs near 2c, where theta is Peirce's 41.5 degrees.
  const float measured_course =
      peirce_bending_length(true, static_cast<int>(std::lround(2 * course / kWale)), material);
  const float measured_wale =
      peirce_bending_length(false, static_cast<int>(std::lround(2 * wale / kCourse)), material);
  EXPECT_NEAR(measured_course / course, 1.0f, 0.1f) << measured_course << " mm vs " << course;
  EXPECT_NEAR(measured_wale / wale, 1.0f, 0.1f) << measured_wale << " mm vs " << wale;
}

// Cloth over a ball hangs: after the sphere scene's 3 s each corner of the
// swatch is below the ball's middle (they stood out level with the top of
// the ball, like wings, when a squeezed course pushed back), and its shadow
// from above, taken as Cusick's drape coefficient takes it (the shadow
// beyond the ball over the cloth beyond the ball), is a limp cloth's.
struct BallDrape {
  float highest_corner = 0;  // mm above the ball's middle
  float highest = 0;         // the cloth's highest point, mm above the ball's top
  float beyond_height = 0;   // the cloth beyond the ball's outline: its mean height above the middle
  float beyond_reach = 0;    // and its mean reach beyond the outline, mm
  float most_stretch = 0;    // the most any course or wale between two stitches is stretched (0.05: 5 %)
  double drape_coefficient = 0;
};

BallDrape drape_over_a_ball(const KnitMaterial& material) {
  const auto chart = load_stitch_chart(std::filesystem::path(PSRIG_SOURCE_DIR) /
                                       "config/patterns/stockinette.chart");
  EXPECT_TRUE(chart);
  auto fabric = KnitFabric::build(*chart, 48, 56, {});
  EXPECT_TRUE(fabric);
  DrapeAnimation scene(std::move(*fabric), DrapeScene::sphere, material);
  for (int frame = 0; frame < 90; ++frame) scene.advance(1.0f / 30);
  const auto& ball = std::get<SphereCollider>(scene.cloth().colliders.front());
  const StitchMesh& mesh = scene.cloth().mesh();
  BallDrape drape;
  drape.highest_corner = -1e9f;
  drape.highest = -1e9f;
  for (const Eigen::Vector3f& v : mesh.vertices)
    drape.highest = std::max(drape.highest, v.y() - ball.centre.y() - ball.radius);
  for (const int column : {0, mesh.columns})
    for (const int row : {0, mesh.rows})
      drape.highest_corner = std::max(drape.highest_corner, mesh.vertex(column, row).y() - ball.centre.y());
  for (int row = 0; row <= mesh.rows; ++row)
    for (int column = 0; column <= mesh.columns; ++column) {
      if (column < mesh.columns)
        drape.most_stretch = std::max(drape.most_stretch, (mesh.vertex(column + 1, row) - mesh.vertex(column, row)).norm() / mesh.face_width_mm - 1);
      if (row < mesh.rows)
        drape.most_stretch = std::max(drape.most_stretch, (mesh.vertex(column, row + 1) - mesh.vertex(column, row)).norm() / mesh.face_height_mm - 1);
    }
  int beyond = 0;
  for (const Eigen::Vector3f& v : mesh.vertices) {
    const float out = std::hypot(v.x() - ball.centre.x(), v.z() - ball.centre.z()) - ball.radius;
    if (out < 1) continue;
    ++beyond;
    drape.beyond_height += v.y() - ball.centre.y();
    drape.beyond_reach += out;
  }
  drape.beyond_height /= static_cast<float>(std::max(beyond, 1));
  drape.beyond_reach /= static_cast<float>(std::max(beyond, 1));
  // The shadow from above: each face's two triangles on a 0.25 mm grid.
  constexpr float cell = 0.25f;
  const float flat_area = mesh.face_width_mm * static_cast<float>(mesh.columns) *
                          mesh.face_height_mm * static_cast<float>(mesh.rows);
  const float reach = 2 * ball.radius + 0.5f * std::sqrt(flat_area);
  DrapeShadow shadow(reach, cell);
  const auto ground = [&](int column, int row) {
    const Eigen::Vector3f& v = mesh.vertex(column, row);
    return Eigen::Vector2f(v.x() - ball.centre.x(), v.z() - ball.centre.z());
  };
  for (int row = 0; row < mesh.rows; ++row)
    for (int column = 0; column < mesh.columns; ++column) {
      shadow.cover(ground(column, row), ground(column + 1, row), ground(column + 1, row + 1));
      shadow.cover(ground(column, row), ground(column + 1, row + 1), ground(column, row + 1));
    }
  const double shadow_area = shadow.area_mm2();
  const double ball_area = std::numbers::pi * ball.radius * ball.radius;
  drape.drape_coefficient = (shadow_area - ball_area) / (flat_area - ball_area);
  return drape;
}

TEST(DrapeScene, ClothOverABallHangs) {
  const BallDrape drape = drape_over_a_ball({});
  std::printf("sphere scene at 3 s: highest corner %.1f mm above the ball's middle; the cloth beyond "
              "the ball %.1f mm above its middle and %.1f mm out; drape coefficient %.2f; stretched at most %.3f\n",
              drape.highest_corner, drape.beyond_height, drape.beyond_reach, drape.drape_coefficient, drape.most_stretch);
  EXPECT_NEAR(drape.highest, 0.5f * KnitMaterial{}.thickness_mm, 0.5f) << "lying on the ball";
  EXPECT_LT(drape.highest_corner, 0);
  // No stitch pulled open: the cloth on the ball's top once crept apart to
  // 4x its length. The strain limit's few passes let a loaded stitch go
  // past the balance interval's 5 %, to 15 % here.
  EXPECT_LT(drape.most_stretch, 5 * KnitMaterial{}.balance_interval);
  EXPECT_LT(drape.drape_coefficient, 0.5);
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
