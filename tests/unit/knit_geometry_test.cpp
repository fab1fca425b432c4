// The knit geometry: stitch mesh, knots and their relaxation, and the yarns
// (issue 5): continuity, interlocking, knit/purl mirror, no self-intersection
// at rest, and Gauss-Newton lowering the energy while keeping the knots'
// constraints.
#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "psrig/cloth/knit_fabric.h"

namespace psrig::cloth {
namespace {

KnitLayout layout_of(int columns, int rows, auto purl) {
  KnitLayout layout{columns, rows, {}, {}};
  for (int row = 0; row < rows; ++row)
    for (int column = 0; column < columns; ++column)
      layout.purl.push_back(purl(column, row) ? 1 : 0);
  return layout;
}

KnitLayout stockinette(int columns, int rows) {
  return layout_of(columns, rows, [](int, int) { return false; });
}

YarnSet yarns_of(const KnitLayout& layout, ClothDeformation deformation = {}, bool relax = true,
                 KnitParameters parameters = {}) {
  KnitFabric fabric = KnitFabric::build(layout, parameters);
  YarnSet yarns;
  fabric.update(fabric.mesh(deformation), yarns, relax);
  return yarns;
}

TEST(KnitGeometry, OneContinuousYarnPerCourseAcrossTheFabric) {
  const KnitParameters parameters;
  const YarnSet yarns = yarns_of(stockinette(7, 5));
  ASSERT_EQ(yarns.curves.size(), 5U);
  for (const YarnCurve& curve : yarns.curves) {
    ASSERT_GT(curve.points.size(), 7U * 14U);
    EXPECT_EQ(curve.normals.size(), curve.points.size());
    EXPECT_EQ(curve.lift.size(), curve.points.size());
    float longest_step = 0, low_x = 1e9f, high_x = -1e9f;
    for (std::size_t i = 0; i < curve.points.size(); ++i) {
      if (i > 0)
        longest_step = std::max(longest_step, (curve.points[i] - curve.points[i - 1]).norm());
      low_x = std::min(low_x, curve.points[i].x());
      high_x = std::max(high_x, curve.points[i].x());
    }
    EXPECT_LT(longest_step, 0.25f * parameters.stitch_width_mm);   // no jumps
    EXPECT_GT(high_x - low_x, 6.5f * parameters.stitch_width_mm);  // all seven stitches
  }
}

// Where two polylines cross seen from the front, which one is in front.
std::vector<float> crossing_depths(const YarnCurve& a, const YarnCurve& b, Eigen::Vector2f low,
                                   Eigen::Vector2f high) {
  const auto inside = [&](const Eigen::Vector3f& p) {
    return p.x() >= low.x() && p.x() <= high.x() && p.y() >= low.y() && p.y() <= high.y();
  };
  std::vector<float> depths;  // z of a minus z of b at each crossing
  for (std::size_t i = 0; i + 1 < a.points.size(); ++i) {
    if (!inside(a.points[i])) continue;
    const Eigen::Vector2f p = a.points[i].head<2>(), r = a.points[i + 1].head<2>() - p;
    for (std::size_t j = 0; j + 1 < b.points.size(); ++j) {
      if (!inside(b.points[j])) continue;
      const Eigen::Vector2f q = b.points[j].head<2>(), s = b.points[j + 1].head<2>() - q;
      const float denominator = r.x() * s.y() - r.y() * s.x();
      if (std::abs(denominator) < 1e-9f) continue;
      const Eigen::Vector2f qp = q - p;
      const float t = (qp.x() * s.y() - qp.y() * s.x()) / denominator;
      const float u = (qp.x() * r.y() - qp.y() * r.x()) / denominator;
      if (t < 0 || t >= 1 || u < 0 || u >= 1) continue;
      const float za = a.points[i].z() + t * (a.points[i + 1].z() - a.points[i].z());
      const float zb = b.points[j].z() + u * (b.points[j + 1].z() - b.points[j].z());
      depths.push_back(za - zb);
    }
  }
  return depths;
}

TEST(KnitGeometry, EachLoopPassesThroughTheLoopBelow) {
  // Seen from the front, the yarns of two neighbouring courses cross within
  // each stitch, the upper one in front at one crossing and behind at
  // another: interlocked, not lying on top of each other.
  for (const bool purl : {false, true}) {
    const int columns = 5, rows = 4;
    const KnitParameters parameters;
    const YarnSet yarns = yarns_of(layout_of(columns, rows, [&](int, int) { return purl; }));
    const float w = parameters.stitch_width_mm, h = parameters.course_height_mm;
    for (int row = 1; row < rows; ++row)
      for (int column = 0; column < columns; ++column) {
        // Stitch (column, row)'s face, in a mesh centred on the origin with one
        // face row more than the courses.
        const Eigen::Vector2f corner(column * w - columns * w / 2, row * h - (rows + 1) * h / 2);
        const std::vector<float> depths =
            crossing_depths(yarns.curves[row], yarns.curves[row - 1], corner,
                            corner + Eigen::Vector2f(w, 0.6f * h));
        const auto in_front =
            std::ranges::count_if(depths, [&](float d) { return d > yarns.style.radius_mm; });
        const auto behind =
            std::ranges::count_if(depths, [&](float d) { return d < -yarns.style.radius_mm; });
        EXPECT_GE(in_front, 1) << "stitch " << column << ", " << row << (purl ? " purl" : " knit");
        EXPECT_GE(behind, 1) << "stitch " << column << ", " << row << (purl ? " purl" : " knit");
      }
  }
}

TEST(KnitGeometry, PurlIsKnitSeenFromTheBack) {
  const YarnSet knit = yarns_of(stockinette(4, 3));
  const YarnSet purl = yarns_of(layout_of(4, 3, [](int, int) { return true; }));
  ASSERT_EQ(knit.curves.size(), purl.curves.size());
  float largest = 0, depth = 0;
  for (std::size_t c = 0; c < knit.curves.size(); ++c) {
    ASSERT_EQ(knit.curves[c].points.size(), purl.curves[c].points.size());
    for (std::size_t i = 0; i < knit.curves[c].points.size(); ++i) {
      const Eigen::Vector3f& k = knit.curves[c].points[i];
      const Eigen::Vector3f& p = purl.curves[c].points[i];
      largest = std::max(largest, (Eigen::Vector3f(k.x(), k.y(), -k.z()) - p).norm());
      depth = std::max(depth, std::abs(k.z()));
    }
  }
  EXPECT_LT(largest, 1e-4f);
  EXPECT_GT(depth, 0.5f * knit.style.radius_mm);  // the mirror is not of a flat thing
}

TEST(KnitGeometry, RibColumnsAlternateFrontAndBack) {
  // A knit loop shows its legs in front and hides its head and sinkers
  // behind, a purl loop the other way round: in a 1x1 rib the yarn's mean
  // depth per column alternates in sign.
  const KnitParameters parameters;
  const YarnSet rib = yarns_of(layout_of(6, 4, [](int column, int) { return column % 2 == 1; }));
  std::array<double, 6> depth{};
  for (const Eigen::Vector3f& p : rib.curves[1].points) {
    const int column = static_cast<int>(std::floor(p.x() / parameters.stitch_width_mm + 3));
    if (column >= 0 && column < 6) depth[column] += p.z();
  }
  for (int column = 0; column < 6; ++column)
    EXPECT_EQ(depth[column] > 0, column % 2 == 1) << column;
}

TEST(KnitGeometry, NoYarnCrossesItselfAtRest) {
  for (const auto& layout :
       {stockinette(5, 4), layout_of(5, 4, [](int c, int r) { return (c + r) % 2; })}) {
    const YarnSet yarns = yarns_of(layout);
    const float radius = yarns.style.radius_mm;
    const float tolerance = 0.3f * radius;
    for (const YarnCurve& curve : yarns.curves) {
      std::vector<float> arc(curve.points.size(), 0.0f);
      for (std::size_t i = 1; i < arc.size(); ++i)
        arc[i] = arc[i - 1] + (curve.points[i] - curve.points[i - 1]).norm();
      float closest = 1e9f;
      for (std::size_t i = 0; i < arc.size(); ++i)
        for (std::size_t j = i + 1; j < arc.size(); ++j)
          if (arc[j] - arc[i] > 4 * radius)  // farther along the yarn than its own bend
            closest = std::min(closest, (curve.points[i] - curve.points[j]).norm());
      EXPECT_GT(closest, 2 * radius - tolerance);
    }
  }
}

TEST(KnotRelaxation, GaussNewtonLowersTheEnergyAndKeepsTheConstraints) {
  KnitFabric fabric = KnitFabric::build(stockinette(6, 5), {});
  YarnSet yarns;
  fabric.update(fabric.mesh({1.4f, 0.3f}), yarns);
  double before = 0, after = 0;
  const float radius = fabric.parameters().style.radius_mm;
  for (int k = 0; k < fabric.knot_count(); ++k) {
    const KnotPlacement& knot = fabric.placement(k);
    const float initial =
        knot_energy(knot, fabric.initial_state(k), fabric.passes(k), fabric.parameters().weights);
    const float relaxed =
        knot_energy(knot, fabric.state(k), fabric.passes(k), fabric.parameters().weights);
    EXPECT_LE(relaxed, initial + 1e-7f) << "knot " << k;
    before += initial;
    after += relaxed;
    // Eq. 4: both yarns' contacts centred on the knot, their side points 2r
    // apart across it, perpendicular to the contacts' direction, in the face.
    const auto passes = fabric.passes(k);
    if (passes.size() < 2) continue;
    const KnotPoints a = knot_points(knot, fabric.state(k), passes[0]);
    const KnotPoints b = knot_points(knot, fabric.state(k), passes[1]);
    const Eigen::Vector3f& n = knot.frame.normal;
    const auto in_plane = [&](const Eigen::Vector3f& v) {
      return Eigen::Vector3f(v - v.dot(n) * n);
    };
    EXPECT_LT(in_plane(0.5f * (a.enter + a.leave) - knot.centre).norm(), 1e-4f);
    EXPECT_LT(((0.5f * (a.beside + b.beside)) - knot.centre).norm(), 1e-4f);
    EXPECT_NEAR((a.beside - b.beside).norm(), 2 * radius, 1e-4f);
    EXPECT_NEAR(in_plane(a.leave - a.enter).normalized().dot((a.beside - b.beside).normalized()),
                0.0f, 1e-4f);
  }
  // The neighbours moved with the stretch, so the energy cannot reach 0;
  // three iterations get where thirty do, well below the initial guess.
  KnitParameters many;
  many.iterations = 30;
  KnitFabric converged = KnitFabric::build(stockinette(6, 5), many);
  converged.update(converged.mesh({1.4f, 0.3f}), yarns);
  double floor = 0;
  for (int k = 0; k < converged.knot_count(); ++k)
    floor +=
        knot_energy(converged.placement(k), converged.state(k), converged.passes(k), many.weights);
  EXPECT_LT(after, 0.8 * before);
  EXPECT_LT(after, 1.01 * floor);
}

// The fabric relaxes its knots four at a time in vector lanes; each must
// come out as relax_knot() gives it alone, the fabric's edge knots (one
// pass) and a batch's unfilled lanes included.
TEST(KnotRelaxation, KnotsRelaxedTogetherMatchEachRelaxedAlone) {
  KnitFabric fabric = KnitFabric::build(stockinette(7, 5), {});
  YarnSet yarns;
  fabric.update(fabric.mesh({1.35f, -0.25f}), yarns);
  int moved = 0;
  for (int k = 0; k < fabric.knot_count(); ++k) {
    const KnotState alone =
        relax_knot(fabric.placement(k), fabric.initial_state(k), fabric.passes(k),
                   fabric.parameters().iterations, fabric.parameters().weights);
    EXPECT_NEAR(fabric.state(k).theta, alone.theta, 1e-6f) << "knot " << k;
    EXPECT_NEAR(fabric.state(k).half_length, alone.half_length, 1e-6f) << "knot " << k;
    moved += std::abs(alone.theta - fabric.initial_state(k).theta) > 1e-3f;
  }
  EXPECT_GT(moved, fabric.knot_count() / 2) << "the stretch gave the relaxation work to do";
}

TEST(KnotRelaxation, AtRestTheTemplateIsAlreadyRelaxed) {
  KnitFabric fabric = KnitFabric::build(stockinette(4, 3), {});
  YarnSet yarns;
  fabric.update(fabric.mesh(), yarns);
  for (int k = 0; k < fabric.knot_count(); ++k) {
    EXPECT_LT(knot_energy(fabric.placement(k), fabric.state(k), fabric.passes(k)), 1e-8f);
    EXPECT_NEAR(fabric.state(k).theta, fabric.initial_state(k).theta, 1e-4f);
  }
}

TEST(KnitGeometry, StretchOpensTheFabricWithoutZigZags) {
  // Stretched 40 % and sheared, the relaxed yarns still turn smoothly: no
  // sample turns by more than a right angle.
  const KnitParameters parameters;
  const YarnSet rest = yarns_of(stockinette(6, 4));
  const YarnSet stretched = yarns_of(stockinette(6, 4), {1.4f, 0.3f});
  const auto width = [](const YarnSet& set) { return set.bounds().sizes().x(); };
  EXPECT_GT(width(stretched), 1.3f * width(rest));
  float sharpest = 0;
  for (const YarnCurve& curve : stretched.curves)
    for (std::size_t i = 1; i + 1 < curve.points.size(); ++i) {
      const Eigen::Vector3f a = (curve.points[i] - curve.points[i - 1]).normalized();
      const Eigen::Vector3f b = (curve.points[i + 1] - curve.points[i]).normalized();
      sharpest = std::max(sharpest, std::acos(std::clamp(a.dot(b), -1.0f, 1.0f)));
    }
  EXPECT_LT(sharpest, 1.2f);  // radians
}

TEST(StitchMesh, DeformationGradientOfAStretchAndShear) {
  const StitchMesh mesh = make_stitch_mesh(3, 3, 5, 4, ClothShape::flat, {1.5f, 0.25f});
  const Eigen::Matrix2f gradient = mesh.deformation_gradient(1, 1);
  EXPECT_NEAR(gradient(0, 0), 1.5f, 1e-5f);
  EXPECT_NEAR(gradient(0, 1), 0.25f, 1e-5f);
  EXPECT_NEAR(gradient(1, 0), 0.0f, 1e-5f);
  EXPECT_NEAR(gradient(1, 1), 1.0f, 1e-5f);
  // Laid on the draped patch, the cloth leaves the plane.
  const StitchMesh draped = make_stitch_mesh(8, 6, 5, 4, ClothShape::draped);
  float depth = 0;
  for (const Eigen::Vector3f& v : draped.vertices)
    depth = std::max(depth, std::abs(v.z()));
  EXPECT_GT(depth, 1.0f);
}

}  // namespace
}  // namespace psrig::cloth
