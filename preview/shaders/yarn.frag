#version 300 es
// Yarn shading per fragment (yarn_fibres.glsl, inserted above, does the
// lighting): the slice (yarn_slice.h, FIBRE_DETAIL) gives the ply offset,
// the fibres' tilt and the fibre-level light at this point of the strip,
// averaged by its mipmaps as the yarn shrinks; the far view's per-vertex
// colour takes over as the yarn narrows to a few pixels (v_detail).
// FAR: that colour alone, for frames whose yarns are all that narrow, as
// transparent as the yarn covers its prefiltered strip (blended in order).
// HALO: the flyaway fibres beside the core, as transparent as the slice is
// thin there. FIBRE_DETAIL, FAR, HALO and ENCODE_SRGB are defines, not
// uniforms: a software rasteriser runs both sides of a branch, so what is
// off must not be there at all.

in vec3 v_far_colour;
in float v_coverage;
#ifdef FAR
in vec4 v_far_coverage;  // distance from the centreline, half width, spread (px), softness
#else
in float v_across;
in vec2 v_uv;
in vec3 v_tangent;
in vec3 v_across_normal;
in vec3 v_facing_normal;
in vec3 v_ply_across;
in vec3 v_to_light;
in vec3 v_to_eye;
in vec3 v_albedo;
in vec3 v_environment_left;
in vec3 v_environment_middle;
in vec3 v_environment_right;
in vec3 v_direct;
in float v_detail;

uniform float u_helix_sin;  // plain fibres: the plies' helix
uniform sampler2D u_slice;
#endif

out vec4 fragment;

#ifdef ENCODE_SRGB
vec3 srgb_encode(vec3 linear) {
  linear = clamp(linear, 0.0, 1.0);
  vec3 low = 12.92 * linear;
  vec3 high = 1.055 * pow(linear, vec3(1.0 / 2.4)) - 0.055;
  return mix(high, low, vec3(lessThanEqual(linear, vec3(0.0031308))));
}
#endif

#ifdef FAR
// The integral of a unit tent of half-width 1 up to y.
float tent_integral(float y) {
  y = clamp(y, -1.0, 1.0);
  return y < 0.0 ? 0.5 * (1.0 + y) * (1.0 + y) : 1.0 - 0.5 * (1.0 - y) * (1.0 - y);
}
#endif

void main() {
#ifdef FAR
  // prefiltered_coverage() in yarn_shading.cpp.
  vec3 colour = v_far_colour;
  float distance = abs(v_far_coverage.x);
  float filter_px = max(v_far_coverage.z, 1e-3);
  float alpha = mix(1.0, tent_integral((distance + v_far_coverage.y) / filter_px) -
                             tent_integral((distance - v_far_coverage.y) / filter_px),
                    v_far_coverage.w);
#else
#ifdef FIBRE_DETAIL
  // Premultiplied by the density (chen2003 eq. 11's averaging in the mipmaps).
  vec4 slice = texture(u_slice, v_uv);
  float inverse = 1.0 / max(slice.a, 1.0 / 255.0);
  vec3 surface = vec3((2.0 * slice.rg - 1.0) * inverse, slice.b * 1.25 * inverse);
#ifdef HALO
  float alpha = slice.a;
#else
  float alpha = v_coverage;
#endif
#else
  vec3 surface = vec3(0.0, u_helix_sin, 1.0);
  float alpha = v_coverage;
#endif
  vec3 near = shade_fibres(v_across, v_across_normal, v_facing_normal, v_tangent, v_ply_across,
                           surface, v_to_light, v_to_eye, v_albedo, v_environment_left,
                           v_environment_middle, v_environment_right, v_direct);
  vec3 colour = mix(v_far_colour, near, v_detail);
#endif
#ifdef ENCODE_SRGB
  colour = srgb_encode(colour);
#endif
  fragment = vec4(colour, alpha);
}
