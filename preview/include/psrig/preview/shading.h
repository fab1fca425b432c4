#pragma once
// The lighting maths of a bump-mapped surface on the CPU: the swatch's and
// the scan's far level on the cloth (shaders/surface_lighting.glsl is its
// GLSL twin, in swatch.frag and scan_surface.frag; keep them in step).
// Everything is in the surface's tangent space, linear light: ambient +
// Lambert diffuse + Blinn-Phong specular scaled by the gloss map, the
// Phong exponent lowered where a mipmap has averaged normals of different
// directions (Toksvig 2005, "Mipmapping normal maps", J. Graphics Tools
// 10(3): the shorter the averaged normal, the wider the highlight), so
// fine knit keeps the highlight its bumps make at a distance instead of
// sparkling (scan_surface_test.cpp measures it).

#include <opencv2/core.hpp>

#include "psrig/cloth/srgb.h"

namespace psrig::preview {

struct ShadingParams {
  float ambient = 0.10f;       // fraction of the albedo seen without the light
  float diffuse = 0.90f;       // Lambert weight
  float specular = 0.25f;      // Blinn-Phong weight at gloss 1
  float shininess = 40.0f;     // Blinn-Phong exponent of a fully resolved normal
  float default_gloss = 0.4f;  // where the maps have no gloss map
  cv::Vec3f light_colour{1.0f, 1.0f, 1.0f};
};

// One texel as the shader samples it.
struct SurfaceSample {
  cv::Vec3f albedo;  // linear RGB
  float alpha = 1;
  cv::Vec3f normal;  // tangent space; shorter than 1 where a mipmap averaged
  float gloss = 0;
};

// Linear RGB and alpha of one surface point. `to_light` and `to_eye` are
// tangent-space and need not be unit length; `attenuation` scales the
// light (1 for a directional light). A light below the surface's
// geometric plane (to_light.z <= 0) lights nothing.
[[nodiscard]] cv::Vec4f shade(const SurfaceSample& sample, cv::Vec3f to_light, cv::Vec3f to_eye,
                              float attenuation, const ShadingParams& params);

// The sRGB transfer functions live with the cloth's colours (psrig/cloth/srgb.h).
using cloth::srgb_decode;
using cloth::srgb_encode;

}  // namespace psrig::preview
