#include "psrig/cloth/knit_fabric.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/LU>

#include "mesh_placement.h"
#include "psrig/base/parallel.h"

namespace psrig::cloth {

Result<KnitFabric> KnitFabric::build(const StitchChart& chart, int columns, int rows,
                                     const KnitParameters& parameters,
                                     std::vector<Eigen::Vector3f> colours) {
  if (chart.columns <= 0 || chart.rows <= 0)
    return std::unexpected(bad_input({}, {}, "the stitch chart " + chart.name + " is empty"));
  if (columns <= 0 || rows <= 0)
    return std::unexpected(bad_input({}, {}, "a knit needs at least one stitch and one course"));
  if (!colours.empty() && colours.size() != static_cast<std::size_t>(columns * rows))
    return std::unexpected(bad_input(
        {}, "colours",
        "one colour per stitch: " + std::to_string(columns * rows) + " for " +
            std::to_string(columns) + " x " + std::to_string(rows) + ", got " +
            std::to_string(colours.size())));
  // The parameters' figures over the chart's.
  const auto over = [](float given, float from_chart) { return given > 0 ? given : from_chart; };
  const KnitGauge gauge{over(parameters.gauge.wales_per_cm, chart.gauge.wales_per_cm),
                        over(parameters.gauge.courses_per_cm, chart.gauge.courses_per_cm),
                        over(parameters.gauge.yarn_diameter_mm, chart.gauge.yarn_diameter_mm)};
  auto dimensions = resolve_knit_gauge(gauge);
  if (!dimensions) return std::unexpected(dimensions.error());

  KnitFabric fabric;
  fabric.chart_ = chart;
  fabric.columns_ = columns;
  fabric.rows_ = rows;
  fabric.parameters_ = parameters;
  fabric.dimensions_ = std::move(*dimensions);
  const bool gauge_given = gauge.wales_per_cm > 0 || gauge.courses_per_cm > 0;
  fabric.repeat_ = knit_repeat_layout(chart, fabric.dimensions_, gauge_given);
  fabric.rest_ =
      knit_rest_cell(chart, fabric.dimensions_, fabric.repeat_, parameters.samples_per_span);
  if (colours.empty() && !chart.palette.empty()) {
    colours.reserve(static_cast<std::size_t>(columns * rows));
    for (int row = 0; row < rows; ++row)
      for (int column = 0; column < columns; ++column)
        colours.push_back(
            chart.palette[static_cast<std::size_t>(chart.colour_at(column, row))]);
  }
  fabric.colours_ = std::move(colours);
  fabric.repeats_ = std::make_shared<RelaxedRepeats>(fabric.rest_, parameters.relax);
  return fabric;
}

YarnStyle KnitFabric::style() const {
  const KnitYarnSection section = knit_yarn_section(dimensions_.yarn_diameter_mm);
  YarnStyle style;
  style.radius_mm = section.half_width_mm;
  style.flatness = section.half_thickness_mm / section.half_width_mm;
  style.plies = parameters_.plies;
  style.twist_pitch_mm = parameters_.twist_pitch_mm;
  style.colour = parameters_.colour;
  return style;
}

StitchMesh KnitFabric::mesh(ClothDeformation deformation) const {
  return make_stitch_mesh(columns_, rows_ + 1, repeat_.width_mm / static_cast<float>(chart_.columns),
                          repeat_.height_mm / static_cast<float>(chart_.rows), parameters_.shape,
                          deformation);
}

YarnSurface KnitFabric::surface(const StitchMesh& mesh) const {
  return {mesh, chart_.columns, chart_.rows};
}

void KnitFabric::update(const StitchMesh& mesh, YarnSet& yarns) {
  // Each stitch's deformation is its own face's; the blends are found (and
  // any new table node relaxed) here, one thread, before placing in parallel.
  const int stitches = columns_ * rows_;
  blends_.resize(static_cast<std::size_t>(stitches));
  const Eigen::Matrix2f corner = mesh.deformation_gradient(0, 0);
  bool uniform = true;
  std::vector<Eigen::Matrix2f> gradients(static_cast<std::size_t>(stitches));
  std::vector<Eigen::Matrix2f> to_rest(static_cast<std::size_t>(stitches));
  for (int row = 0; row < rows_; ++row)
    for (int column = 0; column < columns_; ++column) {
      const auto stitch = static_cast<std::size_t>(row * columns_ + column);
      gradients[stitch] = mesh.deformation_gradient(column, row);
      uniform = uniform && (gradients[stitch] - corner).cwiseAbs().maxCoeff() < 1e-5f;
    }
  if (uniform) {
    std::fill(blends_.begin(), blends_.end(), repeats_->blend(corner));
  } else {
    for (std::size_t stitch = 0; stitch < blends_.size(); ++stitch)
      blends_[stitch] = repeats_->blend(gradients[stitch]);
  }
  // The relaxation's small offsets go back to the cloth at rest through the
  // deformation the blend took (clamped to the table): a face crushed or
  // folded flat has no inverse of its own worth using.
  for (std::size_t stitch = 0; stitch < blends_.size(); ++stitch)
    to_rest[stitch] = blends_[stitch].deformation.inverse();

  const placement::MeshPlacement on_mesh(mesh, Eigen::Matrix2f::Identity());
  const int repeat_columns = chart_.columns, repeat_rows = chart_.rows;
  const float radius = 0.5f * dimensions_.yarn_diameter_mm;
  const bool coloured = !colours_.empty();
  yarns.style = style();
  yarns.surface = surface(mesh);
  yarns.curves.resize(static_cast<std::size_t>(rows_));

  // Each course: every stitch's loop from the repeat at rest, moved by its
  // blend's relaxation (pulled back through its face's deformation, which
  // the mesh puts back), then the next sinker to close it.
  psrig::parallel_chunks(rows_, 4, [&](int begin, int end) {
    for (int row = begin; row < end; ++row) {
      const auto course = static_cast<std::size_t>(row % repeat_rows);
      const CellYarn& source = rest_.yarns[course];
      const std::size_t first_point = repeats_->first_point(course);
      const Eigen::Vector2f up = static_cast<float>(row / repeat_rows) * rest_.a2;
      const std::size_t per_stitch = source.points.size() / static_cast<std::size_t>(repeat_columns);
      const std::size_t count = per_stitch * static_cast<std::size_t>(columns_) + 1;
      YarnCurve& curve = yarns.curves[static_cast<std::size_t>(row)];
      curve.points.resize(count);
      curve.normals.resize(count);
      curve.lift.resize(count);
      curve.colours.resize(coloured ? count : 0);
      std::size_t out = 0;
      const auto emit = [&](std::size_t k, const Eigen::Vector2f& shift, int column) {
        const std::size_t stitch = static_cast<std::size_t>(row * columns_ + column);
        const RelaxedRepeats::Blend& blend = blends_[stitch];
        const Eigen::Vector3f offset = blend.offset(first_point + k);
        Eigen::Vector3f p = source.points[k];
        p.head<2>() += shift + to_rest[stitch] * offset.head<2>();
        p.z() += offset.z();
        on_mesh.place(p, Eigen::Vector2f::Zero(), curve.points[out], curve.normals[out]);
        curve.lift[out] = std::clamp(p.z() / radius, -1.5f, 1.5f);
        if (coloured) curve.colours[out] = colours_[stitch];
        ++out;
      };
      for (int column = 0; column < columns_; ++column) {
        const Eigen::Vector2f shift = static_cast<float>(column / repeat_columns) * rest_.a1 + up;
        const std::size_t first = per_stitch * static_cast<std::size_t>(column % repeat_columns);
        for (std::size_t k = first; k < first + per_stitch; ++k)
          emit(k, shift, column);
      }
      // The sinker after the last loop closes the course.
      emit(per_stitch * static_cast<std::size_t>(columns_ % repeat_columns),
           static_cast<float>(columns_ / repeat_columns) * rest_.a1 + up, columns_ - 1);
    }
  });
}

}  // namespace psrig::cloth
