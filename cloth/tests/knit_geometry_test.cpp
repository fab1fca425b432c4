// The knit geometry (issue 18): gauge in physical units tied by Munden's
// constants, loops interlocked the right way, yarns that touch and never
// pass through each other at rest and deformed, jersey covered by yarn,
// and each shipped chart's structure as it shows on the face and the back,
// measured on the yarns and on head-on rasters of them.
#include <algorithm>
#include <array>
#include <cmath>
#include <map>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "psrig/cloth/knit_fabric.h"
#include "psrig/cloth/yarn_clearance.h"
#include "psrig/cloth/yarn_raster.h"

namespace psrig::cloth {
namespace {

StitchChart chart(const char* name) {
  auto loaded = load_stitch_chart(std::filesystem::path(PSRIG_SOURCE_DIR) / "config/patterns" / name);
  EXPECT_TRUE(loaded) << loaded.error().describe();
  return loaded ? *loaded : StitchChart{};
}

StitchChart chart_of(int columns, int rows, auto purl) {
  StitchChart made{"made", columns, rows, {}, {}, {}, {}};
  for (int row = 0; row < rows; ++row)
    for (int column = 0; column < columns; ++column) {
      made.cells.push_back(purl(column, row) ? Stitch::purl : Stitch::knit);
      made.colour_index.push_back(0);
    }
  return made;
}

KnitFabric fabric_of(const StitchChart& pattern, int columns, int rows) {
  auto fabric = KnitFabric::build(pattern, columns, rows, {});
  EXPECT_TRUE(fabric) << fabric.error().describe();
  return std::move(*fabric);
}

YarnSet yarns_of(KnitFabric& fabric, ClothDeformation deformation = {}) {
  YarnSet yarns;
  fabric.update(fabric.mesh(deformation), yarns);
  return yarns;
}

TEST(KnitGauge, MundensConstantsTieLoopLengthToTheGauge) {
  const auto usual = resolve_knit_gauge({});
  ASSERT_TRUE(usual);
  EXPECT_NEAR(10 / usual->wale_mm, 7.0, 0.1);  // medium-gauge knitwear
  EXPECT_NEAR(10 / usual->course_mm, 9.2, 0.1);
  EXPECT_NEAR(usual->tightness_factor, 1.5, 1e-3);
  // A gauge alone: l = K_w / wales, courses = K_c / l.
  const auto fine = resolve_knit_gauge({10, 0, 0});
  ASSERT_TRUE(fine);
  EXPECT_NEAR(fine->loop_length_mm, 3.8, 1e-3);
  EXPECT_NEAR(10 / fine->course_mm, 5.0 / 0.38, 1e-2);
  EXPECT_NEAR(fine->tightness_factor, 1.5, 1e-3);  // the yarn follows at the usual tightness
  // Everything given is kept.
  const auto given = resolve_knit_gauge({6, 8, 0.5f});
  ASSERT_TRUE(given);
  EXPECT_NEAR(given->wale_mm, 10.0 / 6, 1e-4);
  EXPECT_NEAR(given->course_mm, 10.0 / 8, 1e-4);
  EXPECT_FLOAT_EQ(given->yarn_diameter_mm, 0.5f);
  // A rope at a fine gauge is no knit.
  const auto rope = resolve_knit_gauge({10, 13, 1.5f});
  ASSERT_FALSE(rope);
  EXPECT_EQ(rope.error().kind, ErrorKind::bad_input);
  EXPECT_EQ(rope.error().key, "yarn_mm");
  EXPECT_NE(rope.error().message.find("thinner"), std::string::npos) << rope.error().message;
  EXPECT_FALSE(resolve_knit_gauge({-1, 0, 0}));
}

TEST(KnitGeometry, AJerseyLoopHoldsMundensLoopLength) {
  for (const KnitGauge gauge : {KnitGauge{}, KnitGauge{5, 0, 0}, KnitGauge{0, 0, 0.3f}}) {
    const auto dimensions = resolve_knit_gauge(gauge);
    ASSERT_TRUE(dimensions);
    const StitchChart jersey = chart_of(1, 1, [](int, int) { return false; });
    const YarnCell cell =
        knit_rest_cell(jersey, *dimensions, knit_repeat_layout(jersey, *dimensions, false));
    const CellYarn& yarn = cell.yarns[0];
    float length = 0;
    for (std::size_t k = 0; k < yarn.points.size(); ++k) {
      const Eigen::Vector3f next = k + 1 < yarn.points.size()
                                       ? yarn.points[k + 1]
                                       : yarn.points[0] + Eigen::Vector3f(yarn.period.x(), 0, 0);
      length += (next - yarn.points[k]).norm();
    }
    EXPECT_NEAR(length / dimensions->loop_length_mm, 1.0, 0.05) << dimensions->loop_length_mm;
  }
}

TEST(KnitGeometry, OneContinuousYarnPerCourseAcrossTheFabric) {
  KnitFabric fabric = fabric_of(chart("stockinette.chart"), 7, 5);
  const YarnSet yarns = yarns_of(fabric);
  const float wale = fabric.dimensions().wale_mm;
  ASSERT_EQ(yarns.curves.size(), 5U);
  for (const YarnCurve& curve : yarns.curves) {
    ASSERT_GT(curve.points.size(), 7U * 24U);
    EXPECT_EQ(curve.normals.size(), curve.points.size());
    EXPECT_EQ(curve.lift.size(), curve.points.size());
    float longest_step = 0, low_x = 1e9f, high_x = -1e9f;
    for (std::size_t i = 0; i < curve.points.size(); ++i) {
      if (i > 0)
        longest_step = std::max(longest_step, (curve.points[i] - curve.points[i - 1]).norm());
      low_x = std::min(low_x, curve.points[i].x());
      high_x = std::max(high_x, curve.points[i].x());
    }
    EXPECT_LT(longest_step, 0.25f * wale);   // no jumps
    EXPECT_GT(high_x - low_x, 6.5f * wale);  // all seven stitches
  }
}

// Where two polylines cross seen from the front, a's depth minus b's.
std::vector<float> crossing_depths(const YarnCurve& a, const YarnCurve& b, Eigen::Vector2f low,
                                   Eigen::Vector2f high) {
  const auto inside = [&](const Eigen::Vector3f& p) {
    return p.x() >= low.x() && p.x() <= high.x() && p.y() >= low.y() && p.y() <= high.y();
  };
  std::vector<float> depths;
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
      depths.push_back(a.points[i].z() + t * (a.points[i + 1].z() - a.points[i].z()) -
                       (b.points[j].z() + u * (b.points[j + 1].z() - b.points[j].z())));
    }
  }
  return depths;
}

TEST(KnitGeometry, EachLoopPassesThroughTheLoopBelow) {
  // Seen from the front, the yarns of two neighbouring courses cross within
  // each stitch, the upper one in front at some crossings and behind at
  // others: interlocked, not lying on top of each other.
  for (const bool purl : {false, true}) {
    KnitFabric fabric = fabric_of(chart_of(1, 1, [&](int, int) { return purl; }), 5, 4);
    const YarnSet yarns = yarns_of(fabric);
    const StitchMesh mesh = fabric.mesh();
    for (int row = 1; row < 4; ++row)
      for (int column = 0; column < 5; ++column) {
        const Eigen::Vector2f corner = mesh.vertex(column, row).head<2>();
        const Eigen::Vector2f size(mesh.face_width_mm, 0.6f * mesh.face_height_mm);
        const std::vector<float> depths = crossing_depths(
            yarns.curves[static_cast<std::size_t>(row)],
            yarns.curves[static_cast<std::size_t>(row - 1)], corner - Eigen::Vector2f(0, 0.3f * size.y()),
            corner + size);
        const float thick = fabric.section().half_thickness_mm;
        EXPECT_GE(std::ranges::count_if(depths, [&](float d) { return d > thick; }), 1)
            << "stitch " << column << ", " << row << (purl ? " purl" : " knit");
        EXPECT_GE(std::ranges::count_if(depths, [&](float d) { return d < -thick; }), 1)
            << "stitch " << column << ", " << row << (purl ? " purl" : " knit");
      }
  }
}

TEST(KnitGeometry, PurlIsKnitSeenFromTheBack) {
  KnitFabric knit_fabric = fabric_of(chart_of(1, 1, [](int, int) { return false; }), 4, 3);
  KnitFabric purl_fabric = fabric_of(chart_of(1, 1, [](int, int) { return true; }), 4, 3);
  const YarnSet knit = yarns_of(knit_fabric), purl = yarns_of(purl_fabric);
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
  EXPECT_GT(depth, knit_fabric.section().half_thickness_mm);  // the mirror is not of a flat thing
}

// Every shipped chart, at rest and under the deformations the command line
// allows (stretch 0.5-2, shear to 0.6): yarns touch (clearance about 1) and
// never pass into each other. At a table node of the relaxed repeats the
// shape is relaxed exactly; between nodes it is blended, a little looser.
TEST(KnitGeometry, YarnsTouchAndNeverPassThroughEachOther) {
  const std::vector<std::pair<ClothDeformation, float>> deformations{
      {{1, 0}, 0.95f},    {{0.5f, 0}, 0.95f},   {{2, 0}, 0.95f},
      {{1, 0.5f}, 0.95f}, {{1, -0.5f}, 0.95f}, {{0.625f, 0.25f}, 0.95f},
      {{1.3f, 0.1f}, 0.9f}};  // between nodes
  for (const char* name : {"stockinette.chart", "garter.chart", "rib-1x1.chart", "rib-2x2.chart",
                           "seed.chart", "basketweave.chart", "stripes.chart"}) {
    const StitchChart pattern = chart(name);
    KnitFabric fabric = fabric_of(pattern, std::max(2 * pattern.columns, 6),
                                  std::max(2 * pattern.rows, 6));
    for (const auto& [deformation, least] : deformations) {
      const YarnSet yarns = yarns_of(fabric, deformation);
      const YarnClearance clearance = min_clearance(yarns, fabric.section());
      EXPECT_GE(clearance.clearance, least)
          << name << " stretch " << deformation.stretch << " shear " << deformation.shear
          << ": courses " << clearance.curve_a << " and " << clearance.curve_b << " at points "
          << clearance.point_a << ", " << clearance.point_b;
      EXPECT_LT(clearance.clearance, 1.25f) << name << ": the yarns do not even touch";
    }
  }
}

// Which part of its loop a point of a placed course is (knit_cell.cpp's key
// points, 4 samples between each): 0 sinker, 1 neck, 2 foot, 3 leg, 4 leg
// top, 5 head, 6 crown, then back down 7-11.
enum class Part { leg, bump };
Part part_of(int point) {
  const int key = (point % 48) / 4;
  return (key >= 2 && key <= 4) || (key >= 8 && key <= 10) ? Part::leg : Part::bump;
}

// The head-on raster of `yarns` over the middle of the fabric, and per
// pixel what shows: the course, the stitch column, the part of the loop.
struct View {
  YarnRaster raster;
  std::vector<std::vector<float>> arc;  // per course, per point
};

View view_of(const YarnSet& yarns, Eigen::Vector2d low, Eigen::Vector2d high, double px) {
  const cv::Size size(static_cast<int>((high.x() - low.x()) / px),
                      static_cast<int>((high.y() - low.y()) / px));
  View view{rasterize_yarns(raster_yarns(yarns, low, size, px), size, px, -1e9f, 1e9), {}};
  for (const YarnCurve& curve : yarns.curves) {
    std::vector<float> arc(curve.points.size(), 0.0f);
    for (std::size_t i = 1; i < arc.size(); ++i)
      arc[i] = arc[i - 1] + (curve.points[i] - curve.points[i - 1]).norm();
    view.arc.push_back(std::move(arc));
  }
  return view;
}

// The point of its course a visible pixel shows.
int point_at(const View& view, int row, int column) {
  const int course = view.raster.yarn.at<int>(row, column);
  const std::vector<float>& arc = view.arc[static_cast<std::size_t>(course)];
  const float along = view.raster.along.at<float>(row, column);
  return static_cast<int>(std::lower_bound(arc.begin(), arc.end(), along) - arc.begin());
}

// The share of covered pixels showing legs (the V's), and of those from
// stitches `wanted` says yes to (course, column in the chart's repeat).
struct Shares {
  double legs = 0, wanted = 0, covered = 0;
};
Shares shares_of(const View& view, int repeat_columns, auto wanted) {
  Shares shares;
  double covered = 0;
  for (int r = 0; r < view.raster.yarn.rows; ++r)
    for (int c = 0; c < view.raster.yarn.cols; ++c) {
      const int course = view.raster.yarn.at<int>(r, c);
      if (course < 0) continue;
      ++covered;
      const int point = point_at(view, r, c);
      if (part_of(point) == Part::leg) ++shares.legs;
      if (wanted(course, (point / 48) % repeat_columns)) ++shares.wanted;
    }
  shares.legs /= covered;
  shares.wanted /= covered;
  shares.covered = covered / view.raster.yarn.total();
  return shares;
}

YarnSet mirrored(YarnSet yarns) {  // the back, seen head-on
  for (YarnCurve& curve : yarns.curves)
    for (Eigen::Vector3f& p : curve.points)
      p = {-p.x(), p.y(), -p.z()};
  return yarns;
}

// The middle of a fabric's mesh, a stitch in from every edge.
std::pair<Eigen::Vector2d, Eigen::Vector2d> middle(const StitchMesh& mesh, bool back = false) {
  Eigen::Vector2d low = mesh.vertex(1, 1).head<2>().cast<double>();
  Eigen::Vector2d high = mesh.vertex(mesh.columns - 1, mesh.rows - 2).head<2>().cast<double>();
  if (back) {
    low.x() = -low.x();
    high.x() = -high.x();
    std::swap(low.x(), high.x());
  }
  return {low, high};
}

TEST(KnitGeometry, JerseyFaceShowsVsAndIsCoveredItsBackShowsPurlBumps) {
  KnitFabric fabric = fabric_of(chart("stockinette.chart"), 10, 10);
  const YarnSet yarns = yarns_of(fabric);
  const auto [low, high] = middle(fabric.mesh());
  EXPECT_GE(cover_factor(yarns, low, high - low, 0.01), 0.9);
  const Shares face = shares_of(view_of(yarns, low, high, 0.02), 1, [](int, int) { return true; });
  EXPECT_GE(face.covered, 0.9);
  EXPECT_GE(face.legs, 0.6);  // the V's
  const auto [back_low, back_high] = middle(fabric.mesh(), true);
  const Shares back =
      shares_of(view_of(mirrored(yarns), back_low, back_high, 0.02), 1, [](int, int) { return true; });
  EXPECT_LE(back.legs, 0.4);  // heads and sinkers: purl bumps

  // The V's legs lean in: the visible legs' distance from their wale's
  // middle grows up the leg.
  const KnitRepeatLayout& repeat = fabric.repeat();
  double up_and_out = 0, count = 0;
  for (const YarnCurve& curve : yarns.curves)
    for (std::size_t i = 0; i + 1 < curve.points.size(); ++i) {
      const int key = (static_cast<int>(i) % 48) / 4;
      if (key != 3) continue;  // from the leg toward the leg top, left half
      const Eigen::Vector3f step = curve.points[i + 1] - curve.points[i];
      up_and_out += (step.y() > 0 && step.x() < 0) ? 1 : 0;
      ++count;
    }
  EXPECT_GE(up_and_out / count, 0.9) << repeat.width_mm;
}

TEST(KnitGeometry, RibWalesDrawTogether) {
  // The shipped rib gives its gauge; drawn in from jersey of its yarn, without.
  StitchChart rib = chart("rib-1x1.chart");  // K P
  rib.gauge = {0, 0, rib.gauge.yarn_diameter_mm};
  KnitFabric fabric = fabric_of(rib, 12, 8);
  const YarnSet yarns = yarns_of(fabric);
  // Narrower than two jersey wales, and the knit wales take most of the face.
  EXPECT_LT(fabric.repeat().width_mm, 0.7f * 2 * fabric.dimensions().wale_mm);
  const auto [low, high] = middle(fabric.mesh());
  const Shares face =
      shares_of(view_of(yarns, low, high, 0.02), 2, [&](int course, int column) {
        return rib.at(column, course) == Stitch::knit;
      });
  EXPECT_GE(face.wanted, 0.75);
  EXPECT_GE(face.covered, 0.9);
  const auto [back_low, back_high] = middle(fabric.mesh(), true);
  const Shares back =
      shares_of(view_of(mirrored(yarns), back_low, back_high, 0.02), 2,
                [&](int course, int column) { return rib.at(column, course) == Stitch::purl; });
  EXPECT_GE(back.wanted, 0.75);  // from the back the purl wales are the knit ones
}

TEST(KnitGeometry, GarterShowsHorizontalRidges) {
  StitchChart garter = chart("garter.chart");  // K row, P row
  garter.gauge = {0, 0, garter.gauge.yarn_diameter_mm};
  KnitFabric fabric = fabric_of(garter, 8, 12);
  const YarnSet yarns = yarns_of(fabric);
  EXPECT_LT(fabric.repeat().height_mm, 0.8f * 2 * fabric.dimensions().course_mm);  // crowded
  const auto [low, high] = middle(fabric.mesh());
  const View view = view_of(yarns, low, high, 0.02);
  const Shares face = shares_of(view, 1, [](int, int) { return true; });
  EXPECT_LE(face.legs, 0.45);  // bumps, not V's
  // The face's height, averaged along each raster row, rises and falls once
  // per two courses: ridges across the fabric.
  std::vector<double> profile;
  for (int r = 0; r < view.raster.top.rows; ++r)
    profile.push_back(cv::mean(view.raster.top.row(r))[0]);
  const double period_px = fabric.repeat().height_mm / 0.02;
  double real = 0, imaginary = 0, energy = 0, mean = 0;
  for (const double v : profile) mean += v / static_cast<double>(profile.size());
  for (std::size_t r = 0; r < profile.size(); ++r) {
    const double phase = 2 * M_PI * static_cast<double>(r) / period_px;
    real += (profile[r] - mean) * std::cos(phase);
    imaginary += (profile[r] - mean) * std::sin(phase);
    energy += (profile[r] - mean) * (profile[r] - mean);
  }
  // Most of the profile's variation is at the ridge period.
  const double at_period = 2 * (real * real + imaginary * imaginary) / static_cast<double>(profile.size());
  EXPECT_GE(at_period / energy, 0.5);
}

TEST(KnitGeometry, SeedFaceIsPebbledKnitAndPurlAlternating) {
  const StitchChart seed = chart("seed.chart");
  KnitFabric fabric = fabric_of(seed, 10, 10);
  const YarnSet yarns = yarns_of(fabric);
  const auto [low, high] = middle(fabric.mesh());
  const View view = view_of(yarns, low, high, 0.02);
  // Per stitch, legs show where the chart says knit, bumps where it says
  // purl. A bump is the head of the loop below and the neck and sinkers of
  // the stitch's own course, where its loop was pulled through from the front.
  std::map<std::pair<int, int>, std::pair<double, double>> legs_of;  // (course, column): legs, all
  for (int r = 0; r < view.raster.yarn.rows; ++r)
    for (int c = 0; c < view.raster.yarn.cols; ++c) {
      const int course = view.raster.yarn.at<int>(r, c);
      if (course < 0) continue;
      const int point = point_at(view, r, c);
      const int key = (point % 48) / 4;
      const bool head = key >= 5 && key <= 7;
      auto& [legs, all] = legs_of[{head ? course + 1 : course, point / 48}];
      legs += part_of(point) == Part::leg ? 1 : 0;
      ++all;
    }
  int right = 0, counted = 0;
  for (const auto& [stitch, tally] : legs_of) {
    // Stitches the view's edge cuts: the first course and column in it and the last.
    if (stitch.first < 2 || stitch.first > 7 || stitch.second < 2 || stitch.second > 7) continue;
    const bool looks_knit = tally.first / tally.second > 0.5;
    const bool is_right = looks_knit == (seed.at(stitch.second, stitch.first) == Stitch::knit);
    right += is_right ? 1 : 0;
    ++counted;
  }
  EXPECT_EQ(counted, 36);
  EXPECT_GE(static_cast<double>(right) / counted, 0.95);
}

TEST(KnitGeometry, BadSizesAreClearErrors) {
  const StitchChart jersey = chart("stockinette.chart");
  KnitParameters rope;
  rope.gauge = {12, 0, 1.2f};
  const auto fabric = KnitFabric::build(jersey, 4, 4, rope);
  ASSERT_FALSE(fabric);
  EXPECT_EQ(fabric.error().key, "yarn_mm");
  const auto colours = KnitFabric::build(jersey, 4, 4, {}, {Eigen::Vector3f::Ones()});
  ASSERT_FALSE(colours);
  EXPECT_NE(colours.error().message.find("one colour per stitch: 16"), std::string::npos);
}

}  // namespace
}  // namespace psrig::cloth
