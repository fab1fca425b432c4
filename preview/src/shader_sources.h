#pragma once
// The GLSL of preview/shaders, embedded at build time (cmake/embed_shaders.cmake).

#include <string_view>

namespace psrig::preview::shaders {

struct ShaderSource {
  std::string_view name;  // the file's name, for error messages
  std::string_view text;
};

extern const ShaderSource swatch_vert;
extern const ShaderSource swatch_frag;
extern const ShaderSource surface_lighting_glsl;  // inserted into swatch and scan_surface
extern const ShaderSource light_marker_vert;
extern const ShaderSource light_marker_frag;
extern const ShaderSource yarn_vert;
extern const ShaderSource yarn_frag;
extern const ShaderSource yarn_depth_frag;
extern const ShaderSource yarn_fibres_glsl;  // inserted into both yarn shaders
extern const ShaderSource prop_vert;
extern const ShaderSource prop_frag;
extern const ShaderSource woven_decoder_vert;  // the neural woven BSDF's decoder pass
extern const ShaderSource woven_decoder_frag;
extern const ShaderSource far_cloth_vert;  // the far level (far_cloth.h)
extern const ShaderSource far_cloth_frag;
extern const ShaderSource scan_surface_vert;  // the scan as the far level (scan_surface.h)
extern const ShaderSource scan_surface_frag;
extern const ShaderSource woven_far_vert;  // the neural far level (woven_far_cloth.h)
extern const ShaderSource woven_composite_frag;

}  // namespace psrig::preview::shaders
