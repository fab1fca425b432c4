#pragma once
// The yarn shader's lighting maths on the CPU (shaders/yarn.frag is its
// GLSL twin; keep the two in step). A yarn is drawn as a camera-facing
// strip (huang2025-realtime-knit-deformation-rendering.txt, 5.2): the
// strip coordinate gives the tube's normal, the fibres run along the yarn
// twisted by the plies' helix, and they are lit as hair is: a Kajiya-Kay
// diffuse term and two Kajiya-Kay specular lobes on tangents shifted
// either way, the Marschner R lobe (white) and TRT lobe (the yarn's
// colour). Linear light.

#include <Eigen/Core>

#include "psrig/cloth/yarn_curves.h"

namespace psrig::preview {

struct FibreShading {
  float ambient = 0.15f;  // fraction of the yarn's colour seen without the light
  float diffuse = 0.85f;  // Kajiya-Kay diffuse weight
  // Light wrapping round the tube: the diffuse and specular terms fade out
  // where n.l falls to -wrap (0: a hard terminator at n.l = 0).
  float wrap = 0.5f;
  // R: reflected at the fibre's surface, white, its peak shifted by the
  // tilt of the fibre's scales (a tangent shift along the normal).
  float primary_specular = 0.20f;
  float primary_shift = -0.10f;
  float primary_exponent = 80.0f;
  // TRT: through the fibre and back, coloured, broader, shifted the other way.
  float secondary_specular = 0.30f;
  float secondary_shift = 0.15f;
  float secondary_exponent = 16.0f;
  // Where a yarn passes between the layers (lift 0) neighbours hide most of
  // the sky and the light: all light scales by 1 - crossing_occlusion there.
  float crossing_occlusion = 0.45f;
  float ply_groove = 0.55f;  // darkening in the grooves between plies
  float striation = 0.12f;   // fibre-to-fibre brightness variation, +-
  int fibres_per_ply = 24;   // striation stripes around one ply
  Eigen::Vector3f light_colour{1.0f, 1.0f, 1.0f};
};

// The tube's unit normal at strip coordinate `across` (-1 to 1 across the
// strip, along cross(yarn_tangent, to_eye)): the visible half of the
// cylinder, its middle facing the eye.
[[nodiscard]] Eigen::Vector3f tube_normal(const Eigen::Vector3f& yarn_tangent,
                                          const Eigen::Vector3f& to_eye, float across);

// The helix angle of the plies' centres (half the radius out): the angle
// between the fibres and the yarn's axis.
[[nodiscard]] float ply_helix_angle(const cloth::YarnStyle& style);

// The yarn's tangent turned about the tube's normal by `helix_angle`.
[[nodiscard]] Eigen::Vector3f fibre_tangent(const Eigen::Vector3f& yarn_tangent,
                                            const Eigen::Vector3f& normal, float helix_angle);

// Light scale from a point's lift (yarn_curves.h): 1 at |lift| >= 1.
[[nodiscard]] float crossing_light(float lift, const FibreShading& shading);

// Brightness of the ply grooves and fibre striation at angle `around` the
// yarn (radians, from the cloth's normal toward cross(tangent, normal)) and
// `arc_mm` along it. Both fade to their mean as they shrink below a pixel:
// `fibres_per_pixel` is the striation's screen footprint.
[[nodiscard]] float fibre_detail(float around, float arc_mm, const cloth::YarnStyle& style,
                                 const FibreShading& shading, float fibres_per_pixel = 0);
// What fibre_detail() averages to round the yarn.
[[nodiscard]] float mean_fibre_detail(const FibreShading& shading);

struct FibrePoint {
  Eigen::Vector3f fibre_tangent;  // unit
  Eigen::Vector3f normal;         // unit tube normal
  Eigen::Vector3f colour;         // linear RGB
  float light_scale = 1;          // crossing_light() times fibre_detail()
};

// Linear RGB of one point. `to_light` and `to_eye` need not be unit;
// `attenuation` scales the light (1 for a directional one) and `shadow`
// (0 to 1) is the fraction of it that reaches the point.
[[nodiscard]] Eigen::Vector3f shade_fibres(const FibrePoint& point, const Eigen::Vector3f& to_light,
                                           const Eigen::Vector3f& to_eye, float attenuation,
                                           float shadow, const FibreShading& shading);

}  // namespace psrig::preview
