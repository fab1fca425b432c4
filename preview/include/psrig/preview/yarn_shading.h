#pragma once
// The yarn shaders' maths on the CPU (shaders/yarn.vert and yarn.frag are
// its GLSL twins; keep them in step). A yarn is drawn as a camera-facing
// strip (huang2025-realtime-knit-deformation-rendering.txt, 5.2) as wide
// as its elliptical cross-section looks from the eye (yarn_curves.h: radius
// across in the cloth's plane, flatness * radius along the cloth's normal);
// the strip coordinate gives the point of the ellipse seen there and its
// normal. Per vertex (cheap: a vertex is shared by many fragments) come
// the light from the environment map at three points across the strip,
// the shadow and the yarn's colour; per fragment the fibres' lobes of
// huang2025 eq. 7: a Kajiya-Kay diffuse lobe D, a white reflection R
// shifted by the fibres' scales and a coloured transmission TT forward
// through them, longitudinal Gaussians in the half angle times azimuthal
// terms. Multiple scattering between fibres is approximated after
// huang2025 eq. 8 (dual scattering: a global part, light passed on through
// yarns into their shadows and round their terminator, and a local part,
// the light scattered again nearby, a geometric series in the albedo), so
// light yarn glows and dark yarn does not. Linear light.

#include <array>

#include <Eigen/Core>

#include "psrig/cloth/yarn_curves.h"
#include "psrig/preview/environment_light.h"
#include "psrig/preview/yarn_slice.h"

namespace psrig::preview {

struct FibreShading {
  float diffuse = 0.85f;  // D: Kajiya-Kay diffuse weight
  // Light wrapping round the yarn: direct light fades out where n.l falls
  // to -wrap (0: a hard terminator).
  float wrap = 0.35f;
  // R and TT: weight, longitudinal shift and width, both as sines of the
  // half angle between the fibre's normal plane and the light and eye.
  float r_weight = 0.25f;
  float r_shift = -0.10f;
  float r_width = 0.14f;
  float tt_weight = 0.45f;
  float tt_shift = 0.05f;
  float tt_width = 0.10f;
  // Multiple scattering (dual scattering, huang2025 eq. 8): local, the
  // share of scattered light that scatters again nearby, each bounce
  // taking the albedo once more (diffuse light times 1 + s a / (1 - s a));
  // global, the share of a yarn's albedo it passes on through itself into
  // its own and other yarns' shadows and round its terminator.
  float local_scattering = 0.35f;
  float global_scattering = 0.45f;
  // Environment light: its scale, the share of it a fibre takes through
  // its Kajiya-Kay lobe (the rest through the tube's cosine), and the R
  // lobe's sheen of it.
  float environment = 1.0f;
  float environment_fibre = 0.5f;
  float environment_sheen = 0.12f;
  // Where a yarn passes between the layers (lift 0) neighbours hide most of
  // the sky and the light: all light scales by 1 - crossing_occlusion there.
  float crossing_occlusion = 0.45f;
  float ply_relief = 0.6f;  // how far the plies' roundness tilts the normal
  // Yarn-level shadows where the yarns are too small for the shadow map: a
  // point at depth d (0 on top of the cloth, 1 under it, from its lift)
  // keeps exp(-shadow_density * d * tan(slant)) of the light.
  float shadow_density = 0.15f;
  Eigen::Vector3f light_colour{1.0f, 1.0f, 1.0f};
};

// How a strip faces the eye at one centreline point (yarn.vert's work).
struct StripFrame {
  Eigen::Vector3f tangent;  // unit, along the yarn
  Eigen::Vector3f side;     // unit, across the strip: cross(tangent, facing)
  Eigen::Vector3f facing;   // unit, toward the eye, normal to the tangent
  // The ellipse's normal at strip coordinate a is
  // normalize(a * across_normal + sqrt(1 - a^2) * facing_normal).
  Eigen::Vector3f across_normal, facing_normal;
  float half_width_mm = 0;  // the ellipse's silhouette, half
  // Where the slice's pattern stands for this view: the baked view looks
  // along the cloth's normal; another turns the plies' helix, which reads
  // as the pattern moved along the yarn by this many twist pitches.
  float turn = 0;
};

// `to_eye` (or to the light, for the shadow map's strips) need not be unit.
[[nodiscard]] StripFrame strip_frame(const Eigen::Vector3f& tangent,
                                     const Eigen::Vector3f& cloth_normal,
                                     const Eigen::Vector3f& to_eye, float radius_mm,
                                     float flatness);

// The ellipse's unit normal at strip coordinate `across` (clamped to -1..1).
[[nodiscard]] Eigen::Vector3f strip_normal(const StripFrame& frame, float across);

// The ellipse's point nearest the light, relative to the centreline (the
// shadow map is looked up there: its own strip lies through the centre).
[[nodiscard]] Eigen::Vector3f toward_light_surface(const Eigen::Vector3f& tangent,
                                                   const Eigen::Vector3f& cloth_normal,
                                                   const Eigen::Vector3f& to_light,
                                                   float radius_mm, float flatness);

// The angle between the fibres of the plies' centres and the yarn's axis.
[[nodiscard]] float ply_helix_angle(const cloth::YarnStyle& style);

// Light scale from a point's lift (yarn_curves.h): 1 at |lift| >= 1.
[[nodiscard]] float crossing_light(float lift, const FibreShading& shading);

// The share of a light's direct light that reaches a point by the
// statistical yarn shadows (shadow_density), from its lift.
[[nodiscard]] float statistical_shadow(float lift, const Eigen::Vector3f& cloth_normal,
                                       const Eigen::Vector3f& to_light,
                                       const FibreShading& shading);

// Multiple scattering's gain on diffuse light: 1 + s a / (1 - s a).
[[nodiscard]] Eigen::Vector3f local_scattering_gain(const Eigen::Vector3f& albedo,
                                                    const FibreShading& shading);
// Light reaching a point shadowed to `shadow` (0 to 1) once the yarns in
// the way pass some on: shadow + (1 - shadow) g a.
[[nodiscard]] Eigen::Vector3f transmitted_shadow(float shadow, const Eigen::Vector3f& albedo,
                                                 const FibreShading& shading);

// The environment's light leaving a yarn point with normal `normal` on a
// yarn along `tangent`, seen from `to_eye`.
[[nodiscard]] Eigen::Vector3f environment_shading(const EnvironmentLight& environment,
                                                  const Eigen::Vector3f& normal,
                                                  const Eigen::Vector3f& tangent,
                                                  const Eigen::Vector3f& to_eye,
                                                  const Eigen::Vector3f& albedo,
                                                  const FibreShading& shading);

// What yarn.vert hands each fragment, for one centreline point.
struct VertexShading {
  std::array<Eigen::Vector3f, 3> environment;  // at strip coordinates -1, 0, 1
  Eigen::Vector3f direct;  // light colour x attenuation x crossing x transmitted shadow
  Eigen::Vector3f albedo;
};

// `shadow` 0 to 1: the share of the light the shadows let through.
[[nodiscard]] VertexShading vertex_shading(const StripFrame& frame, const Eigen::Vector3f& albedo,
                                           float lift, const Eigen::Vector3f& to_eye,
                                           float attenuation, float shadow,
                                           const EnvironmentLight& environment,
                                           const FibreShading& shading);

// The environment's light at strip coordinate `across`, interpolated
// quadratically through the three per-vertex values.
[[nodiscard]] Eigen::Vector3f environment_across(const VertexShading& vertex, float across);

// The fibre-level look at a fragment: the slice's sample, or (plain
// fibres) the plies' helix with no relief.
struct FibreSurface {
  float ply_offset = 0;
  float tilt_sin = 0;
  float light = 1;
};
[[nodiscard]] FibreSurface plain_surface(const cloth::YarnStyle& style);
[[nodiscard]] FibreSurface slice_surface(const SliceSample& sample);

// Linear RGB of one fragment at strip coordinate `across`. `to_light` and
// `to_eye` need not be unit; `ply_across` is the direction the slice's ply
// offset tilts the normal (yarn.vert's: across the plies' slant).
[[nodiscard]] Eigen::Vector3f shade_fragment(const StripFrame& frame, float across,
                                             const FibreSurface& surface,
                                             const Eigen::Vector3f& ply_across,
                                             const VertexShading& vertex,
                                             const Eigen::Vector3f& to_light,
                                             const Eigen::Vector3f& to_eye,
                                             const FibreShading& shading);

// The far view's coverage at `distance_px` from a yarn's centreline: its
// width (2 half_px) convolved with a unit-area tent of half-width
// `filter_px` (a prefilter the strip is widened by; 0: the yarn's own edges).
[[nodiscard]] float prefiltered_coverage(float distance_px, float half_px, float filter_px);

// The direction across the plies where they face the eye: the strip's side
// turned by the plies' slant toward the tangent.
[[nodiscard]] Eigen::Vector3f ply_across_direction(const StripFrame& frame, float ply_slant_sin);

}  // namespace psrig::preview
