#include "psrig/cloth/woven_fabric.h"

#include <algorithm>

#include <Eigen/LU>

#include "mesh_placement.h"
#include "psrig/base/parallel.h"

namespace psrig::cloth {

Result<WovenFabric> WovenFabric::build(const WeaveMatrix& weave, int warps, int wefts,
                                       const WovenParameters& parameters) {
  if (weave.warps <= 0 || weave.wefts <= 0)
    return std::unexpected(bad_input({}, {}, "the weave " + weave.name + " is empty"));
  if (warps <= 0 || wefts <= 0)
    return std::unexpected(bad_input({}, {}, "a woven cloth needs at least one warp and one weft"));
  const auto over = [](float given, float from_weave) { return given > 0 ? given : from_weave; };
  auto dimensions = resolve_woven_gauge(
      {over(parameters.gauge.ends_per_cm, weave.gauge.ends_per_cm),
       over(parameters.gauge.picks_per_cm, weave.gauge.picks_per_cm),
       over(parameters.gauge.yarn_diameter_mm, weave.gauge.yarn_diameter_mm)});
  if (!dimensions) return std::unexpected(dimensions.error());
  WovenFabric fabric;
  fabric.weave_ = weave;
  fabric.warps_ = warps;
  fabric.wefts_ = wefts;
  fabric.parameters_ = parameters;
  fabric.dimensions_ = std::move(*dimensions);
  fabric.warp_colour_ = parameters.warp_colour.value_or(
      weave.warp_colour.value_or(Eigen::Vector3f(0.16f, 0.22f, 0.45f)));
  fabric.weft_colour_ = parameters.weft_colour.value_or(
      weave.weft_colour.value_or(Eigen::Vector3f(0.75f, 0.72f, 0.64f)));
  fabric.rest_ = woven_rest_cell(weave, fabric.dimensions_, parameters.samples_per_crossing);
  fabric.repeats_ = std::make_shared<RelaxedRepeats>(fabric.rest_, parameters.relax);
  return fabric;
}

YarnStyle WovenFabric::style() const {
  YarnStyle style;
  style.radius_mm = dimensions_.half_width_mm;
  style.flatness = dimensions_.half_thickness_mm / dimensions_.half_width_mm;
  style.plies = parameters_.plies;
  style.twist_pitch_mm = parameters_.twist_pitch_mm;
  style.colour = warp_colour_;
  return style;
}

StitchMesh WovenFabric::mesh(ClothDeformation deformation) const {
  return make_stitch_mesh(warps_, wefts_, dimensions_.end_spacing_mm, dimensions_.pick_spacing_mm,
                          parameters_.shape, deformation);
}

void WovenFabric::update(const StitchMesh& mesh, YarnSet& yarns) {
  YarnCell cell;
  repeats_->shape(placement::mean_deformation(mesh), cell);
  Eigen::Matrix2f shaped;  // as shape() took it: in the course's frame
  shaped << cell.a1.x() / rest_.a1.x(), cell.a2.x() / rest_.a2.y(), 0, cell.a2.y() / rest_.a2.y();
  const placement::MeshPlacement on_mesh(mesh, shaped.inverse());
  const float depth = dimensions_.half_thickness_mm;
  yarns.style = style();
  yarns.surface = {mesh, weave_.warps, weave_.wefts};
  yarns.curves.resize(static_cast<std::size_t>(warps_ + wefts_));
  psrig::parallel_chunks(warps_ + wefts_, 8, [&](int begin, int end) {
    for (int thread = begin; thread < end; ++thread) {
      const bool warp = thread < warps_;
      const int index = warp ? thread : thread - warps_;
      const int repeat = warp ? weave_.warps : weave_.wefts;       // threads in a repeat
      const int crossings = warp ? wefts_ : warps_;                 // along this thread
      const int period = warp ? weave_.wefts : weave_.warps;        // crossings in a repeat
      const CellYarn& source =
          cell.yarns[static_cast<std::size_t>((warp ? 0 : weave_.warps) + index % repeat)];
      const Eigen::Vector2f beside = static_cast<float>(index / repeat) * (warp ? cell.a1 : cell.a2);
      const Eigen::Vector3f colour = warp ? warp_colour_ : weft_colour_;
      YarnCurve& curve = yarns.curves[static_cast<std::size_t>(thread)];
      curve.points.clear();
      curve.normals.clear();
      curve.lift.clear();
      curve.colours.clear();
      bool done = false;
      for (int tile = 0; !done && tile * period < crossings; ++tile) {
        const Eigen::Vector2f shift = beside + static_cast<float>(tile) * source.period;
        for (std::size_t k = 0; k < source.points.size(); ++k) {
          // The thread runs from the first crossing to the last: the cloth's edges.
          const int crossing = tile * period + source.stitch[k];
          const bool span_start = k == 0 || source.stitch[k - 1] != source.stitch[k];
          if (crossing > crossings - 1 || (crossing == crossings - 1 && !span_start)) {
            done = true;
            break;
          }
          Eigen::Vector3f position, normal;
          on_mesh.place(source.points[k], shift, position, normal);
          curve.points.push_back(position);
          curve.normals.push_back(normal);
          curve.lift.push_back(std::clamp(source.points[k].z() / depth, -1.5f, 1.5f));
          curve.colours.push_back(colour);
        }
      }
    }
  });
}

}  // namespace psrig::cloth
