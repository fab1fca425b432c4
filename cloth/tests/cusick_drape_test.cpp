// Cusick's drape test (BS 5058:1973, ISO 9073-9's drapemeter), simulated:
// a circular specimen 30 cm across, held between two discs 18 cm across,
// drapes under its own weight into folds; the drape coefficient is its
// shadow from above beyond the disc over its area beyond the disc (0: it
// hangs straight down, 1: it stays flat). The rectangular stitch mesh is
// cut to the circle (StitchCloth::cut) and the discs are pins.

#include <cmath>
#include <cstdio>
#include <numbers>

#include <gtest/gtest.h>

#include "drape_shadow.h"
#include "psrig/cloth/stitch_cloth.h"

namespace psrig::cloth {
namespace {

struct CusickResult {
  double drape_coefficient = 0;
  int nodes = 0;        // folds round the specimen
  float lowest_mm = 0;  // the edge's lowest point below the disc
};

CusickResult cusick(const KnitMaterial& material) {
  constexpr float kSpecimen = 150, kDisc = 90;  // radii, mm
  // Faces coarser than a stitch (the material is per unit width, so the
  // cloth's stiffness is the same); 5 mm resolves folds centimetres long.
  constexpr float kFace = 5;
  constexpr int kFaces = 64;
  // A specimen is never perfectly flat: a ripple of a fraction of a
  // millimetre, which a perfectly symmetric sheet needs to buckle at all.
  StitchMesh flat = make_stitch_mesh(kFaces, kFaces, kFace, kFace, ClothShape::flat);
  for (Eigen::Vector3f& v : flat.vertices)
    v.z() =
        0.3f * std::sin(0.37f * v.x() + 0.11f * v.y()) * std::cos(0.23f * v.y() - 0.05f * v.x());
  StitchCloth cloth(flat, material);
  const StitchMesh& rest = cloth.mesh();
  std::vector<bool> removed(rest.vertices.size());
  for (std::size_t i = 0; i < rest.vertices.size(); ++i)
    removed[i] = rest.vertices[i].head<2>().norm() > kSpecimen;
  cloth.cut(removed);
  for (int row = 0; row <= kFaces; ++row)
    for (int column = 0; column <= kFaces; ++column)
      if (rest.vertex(column, row).head<2>().norm() <= kDisc) cloth.pin(column, row);
  for (int frame = 0; frame < 600; ++frame)
    cloth.step(1.0f / 60);

  // The shadow from above of every face left whole, on a 1 mm grid.
  const StitchMesh& mesh = cloth.mesh();
  constexpr float kCell = 1;
  DrapeShadow shadow(kSpecimen + 10, kCell);
  CusickResult result;
  const auto index = [&](int column, int row) {
    return static_cast<std::size_t>(row * (kFaces + 1) + column);
  };
  double cut_area = 0;  // the specimen as the mesh cuts it (its faces left whole)
  for (int row = 0; row < kFaces; ++row)
    for (int column = 0; column < kFaces; ++column) {
      if (removed[index(column, row)] || removed[index(column + 1, row)] ||
          removed[index(column, row + 1)] || removed[index(column + 1, row + 1)])
        continue;
      cut_area += kFace * kFace;
      const auto at = [&](int c, int r) { return Eigen::Vector2f(mesh.vertex(c, r).head<2>()); };
      shadow.cover(at(column, row), at(column + 1, row), at(column + 1, row + 1));
      shadow.cover(at(column, row), at(column + 1, row + 1), at(column, row + 1));
    }
  const double shadow_area = shadow.area_mm2();
  const double disc_area = std::numbers::pi * kDisc * kDisc;
  result.drape_coefficient = (shadow_area - disc_area) / (cut_area - disc_area);
  // Nodes: along each ray from the centre the shadow's reach; a fold is
  // a run of rays reaching further than the mean.
  constexpr int kRays = 720;
  std::vector<double> reach(kRays, 0);
  for (int ray = 0; ray < kRays; ++ray) {
    const double angle = 2 * std::numbers::pi * ray / kRays;
    for (double r = kDisc; r <= kSpecimen + 5; r += 0.5) {
      if (shadow.covers(
              {static_cast<float>(r * std::cos(angle)), static_cast<float>(r * std::sin(angle))}))
        reach[ray] = r;
    }
  }
  // Smoothed over 10 degrees: a node is a fold, not the mesh's jag.
  std::vector<double> smooth(kRays, 0);
  double mean = 0;
  for (int ray = 0; ray < kRays; ++ray) {
    for (int k = -10; k <= 10; ++k)
      smooth[ray] += reach[(ray + k + kRays) % kRays] / 21;
    mean += smooth[ray] / kRays;
  }
  int changes = 0;
  for (int ray = 0; ray < kRays; ++ray)
    changes += (smooth[ray] > mean) != (smooth[(ray + 1) % kRays] > mean);
  result.nodes = changes / 2;
  for (const Eigen::Vector3f& v : mesh.vertices)
    result.lowest_mm = std::min(result.lowest_mm, v.z());
  return result;
}

// Disabled until the cloth folds into nodes: jersey (the default
// material: 220 g/m^2, bending 1 and 2 uN m) drapes to a coefficient of
// 0.09 (0.10 with no free squeeze) and hangs from the disc as a
// near-vertical skirt (its edge 64 mm below the disc, 60 mm out), rippled
// into about 10 small folds that barely reach past the disc, where
// Cusick's specimens fall into 4 to 8 nodes (the method as described at
// https://mapofsciences.com/topic/drape-coefficient-testing/). Not for
// want of self-collision: a repulsion keeping masses 3 mm apart found no
// two that near (cloth/README.md), nor of resolution (4 mm faces: 0.11, 8
// nodes; 2.5 mm: 0.10, 11). No published drape coefficient of single
// jersey was at hand to compare the 0.09 with.
TEST(CusickDrape, DISABLED_SingleJerseyFallsIntoNodes) {
  const CusickResult jersey = cusick({});
  std::printf("Cusick: drape coefficient %.2f, %d nodes, the edge %.0f mm below the disc\n",
              jersey.drape_coefficient, jersey.nodes, -jersey.lowest_mm);
  EXPECT_GE(jersey.nodes, 4);
  EXPECT_LE(jersey.nodes, 8);
}

// What the drapemeter finds across fabrics (Cusick, "The measurement of
// fabric drape", J. Textile Inst. 1968, and the studies since): the
// stiffer in bending, the wider the shadow and the fewer and larger its
// nodes. The
// same jersey at 1, 4 and 16 times its bending rigidity (its bending
// length 1, 1.6 and 2.5 times as long): the coefficient grows each time
// (measured 0.09, 0.17, 0.35), the nodes never grow in number (10, 8, 6)
// and the stiffest falls into Cusick's 4 to 8. A shear or tensile
// stiffness ten times as high or no free squeeze moves the coefficient by
// 0.03 at most: bending is what the drape test measures, here as on the
// instrument.
TEST(CusickDrape, StifferInBendingDrapesWiderInFewerNodes) {
  CusickResult previous;
  previous.nodes = 1000;
  for (const float scale : {1.0f, 4.0f, 16.0f}) {
    KnitMaterial material;
    material.course_bending_un_m *= scale;
    material.wale_bending_un_m *= scale;
    const CusickResult drape = cusick(material);
    std::printf("Cusick: bending x%.0f: drape coefficient %.2f, %d nodes\n", scale,
                drape.drape_coefficient, drape.nodes);
    EXPECT_GT(drape.drape_coefficient, previous.drape_coefficient + 0.04) << scale;
    EXPECT_LE(drape.nodes, previous.nodes) << scale;
    previous = drape;
  }
  EXPECT_GE(previous.nodes, 4);
  EXPECT_LE(previous.nodes, 8);
}

}  // namespace
}  // namespace psrig::cloth
