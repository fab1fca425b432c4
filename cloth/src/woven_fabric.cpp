#include "psrig/cloth/woven_fabric.h"

#include <vector>

#include "psrig/cloth/yarn_spline.h"

namespace psrig::cloth {

StitchMesh woven_mesh(int warps, int wefts, const WovenParameters& parameters,
                      ClothDeformation deformation) {
  return make_stitch_mesh(warps, wefts, parameters.spacing_mm, parameters.spacing_mm,
                          parameters.shape, deformation);
}

void weave_yarns(const WeaveMatrix& weave, const StitchMesh& mesh,
                 const WovenParameters& parameters, YarnSet& yarns) {
  const int warps = mesh.columns, wefts = mesh.rows;
  const float radius = parameters.style.radius_mm;
  yarns.style = parameters.style;
  yarns.curves.resize(static_cast<std::size_t>(warps + wefts));
  std::vector<YarnControlPoint> control;
  // A thread's control point at the middle of crossing (warp, weft), and at
  // the cloth's edge where it leaves.
  const auto crossing = [&](int warp, int weft, float u, float v, float lift,
                            const Eigen::Vector3f& colour) {
    const Eigen::Vector3f normal = mesh.frame(warp, weft).normal;
    control.push_back(
        {mesh.point(warp, weft, u, v) + lift * radius * normal, normal, lift, colour});
  };
  for (int warp = 0; warp < warps; ++warp) {
    control.clear();
    const auto lift = [&](int weft) { return weave.warp_over(warp, weft) ? 1.0f : -1.0f; };
    crossing(warp, 0, 0.5f, 0.0f, lift(0), parameters.style.colour);
    for (int weft = 0; weft < wefts; ++weft)
      crossing(warp, weft, 0.5f, 0.5f, lift(weft), parameters.style.colour);
    crossing(warp, wefts - 1, 0.5f, 1.0f, lift(wefts - 1), parameters.style.colour);
    sample_yarn(control, parameters.samples_per_span, true,
                yarns.curves[static_cast<std::size_t>(warp)]);
  }
  for (int weft = 0; weft < wefts; ++weft) {
    control.clear();
    const auto lift = [&](int warp) { return weave.warp_over(warp, weft) ? -1.0f : 1.0f; };
    crossing(0, weft, 0.0f, 0.5f, lift(0), parameters.weft_colour);
    for (int warp = 0; warp < warps; ++warp)
      crossing(warp, weft, 0.5f, 0.5f, lift(warp), parameters.weft_colour);
    crossing(warps - 1, weft, 1.0f, 0.5f, lift(warps - 1), parameters.weft_colour);
    sample_yarn(control, parameters.samples_per_span, true,
                yarns.curves[static_cast<std::size_t>(warps + weft)]);
  }
}

}  // namespace psrig::cloth
