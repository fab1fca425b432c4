#version 300 es
// Per-pixel lighting of the swatch (surface_lighting.glsl, inserted before
// these lines; shading.cpp is its CPU twin). Linear light throughout; the
// framebuffer encodes sRGB, or this shader does when u_encode_srgb is set.
precision highp float;

in vec3 v_to_light;
in vec3 v_to_eye;
in vec2 v_uv;

uniform sampler2D u_albedo_alpha;  // sRGB texture: decoded to linear by GL
uniform sampler2D u_normal_gloss;  // averaged tangent normal, gloss
uniform float u_ambient;
uniform vec3 u_light_colour;
uniform float u_point_light;         // 1: attenuate by distance
uniform float u_reference_distance;  // a point light's full-strength distance
uniform bool u_encode_srgb;

out vec4 fragment;

vec3 srgb_encode(vec3 linear) {
  linear = clamp(linear, 0.0, 1.0);
  vec3 low = 12.92 * linear;
  vec3 high = 1.055 * pow(linear, vec3(1.0 / 2.4)) - 0.055;
  return mix(high, low, vec3(lessThanEqual(linear, vec3(0.0031308))));
}

void main() {
  vec4 albedo = texture(u_albedo_alpha, v_uv);
#ifdef ALPHA_MAP  // only then: a shader that may discard is slower everywhere
  if (albedo.a < 0.5 / 255.0) discard;  // trimmed away
#endif
  vec4 normal_gloss = texture(u_normal_gloss, v_uv);
  vec3 to_light = v_to_light;
  vec3 to_eye = v_to_eye;
  if (!gl_FrontFacing) {  // the back of the sheet: shade it as a mirror of the front
    to_light.z = -to_light.z;
    to_eye.z = -to_eye.z;
  }
  float attenuation = u_point_light > 0.5
      ? u_reference_distance * u_reference_distance / dot(to_light, to_light)
      : 1.0;
  vec3 colour = surface_lighting(albedo.rgb, normal_gloss, to_light, to_eye, vec3(u_ambient),
                                 u_light_colour * attenuation);
  fragment = vec4(u_encode_srgb ? srgb_encode(colour) : colour, albedo.a);
}
