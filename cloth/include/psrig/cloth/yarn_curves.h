#pragma once
// Yarn centrelines: what the knit and woven geometry hands the yarn renderer.
// Axes are the scan's (docs/design.md "Axes and units"): the cloth's front faces +z when flat,
// courses run along +x, wales along +y (row 0 at the bottom). Millimetres.

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "psrig/cloth/stitch_mesh.h"

namespace psrig::cloth {

// How a yarn looks, the same for every yarn of a fabric.
struct YarnStyle {
  // The cross-section is an ellipse: radius_mm across the yarn in the
  // cloth's plane (half its width seen head-on), flatness * radius_mm along
  // the cloth's normal (half its thickness). Yarn in cloth is pressed flat
  // where it crosses other yarn: knits about 0.6, wovens 0.3-0.5; 1 is round.
  float radius_mm = 0.6f;
  float flatness = 1.0f;
  int plies = 2;                                // plies twisted together, at least 1
  float twist_pitch_mm = 2.5f;                  // yarn length per full turn of the plies
  // Flyaway fibres standing out of the yarn, relative to a typical spun
  // yarn's (1); 0 for a smooth filament. Only renderers read it.
  float hairiness = 1.0f;
  Eigen::Vector3f colour{0.55f, 0.18f, 0.12f};  // linear RGB, when a curve has none
};

// One yarn, sampled densely enough to draw as straight pieces.
struct YarnCurve {
  std::vector<Eigen::Vector3f> points;   // centreline, in order along the yarn
  std::vector<Eigen::Vector3f> normals;  // unit normal of the cloth's front at each point
  // Signed offset of each point from the cloth's middle surface along
  // normals, in yarn radii: about +1 where the yarn lies on the front of a
  // crossing, -1 behind one, 0 where it passes between the layers.
  std::vector<float> lift;
  std::vector<Eigen::Vector3f> colours;  // linear RGB per point; empty: the style's colour
};

// The surface the yarns lie on: the stitch mesh, and how many of its faces
// one repeat of the pattern spans (the yarns of faces repeat_columns apart,
// or repeat_rows apart, are the same yarns moved by the faces). What a
// renderer needs to draw cloth too far off to show its yarns as a surface
// textured with one repeat (preview's far level). No faces: none given.
struct YarnSurface {
  StitchMesh mesh;
  int repeat_columns = 0, repeat_rows = 0;

  [[nodiscard]] bool empty() const {
    return mesh.columns < repeat_columns || mesh.rows < repeat_rows || repeat_columns <= 0 ||
           repeat_rows <= 0;
  }
};

struct YarnSet {
  std::vector<YarnCurve> curves;
  YarnStyle style;
  YarnSurface surface;

  // Every point's bounding box, grown by the yarn radius.
  [[nodiscard]] Eigen::AlignedBox3f bounds() const {
    Eigen::AlignedBox3f box;
    for (const YarnCurve& curve : curves)
      for (const Eigen::Vector3f& point : curve.points)
        box.extend(point);
    if (!box.isEmpty()) {
      box.min().array() -= style.radius_mm;
      box.max().array() += style.radius_mm;
    }
    return box;
  }
  [[nodiscard]] std::size_t point_count() const {
    std::size_t count = 0;
    for (const YarnCurve& curve : curves)
      count += curve.points.size();
    return count;
  }
};

}  // namespace psrig::cloth
