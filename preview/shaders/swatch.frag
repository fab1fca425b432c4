#version 300 es
// Per-pixel lighting of the swatch; shading.cpp is the CPU twin of these
// lines, keep the two in step. Linear light throughout; the framebuffer
// encodes sRGB, or this shader does when u_encode_srgb is set.
precision highp float;

in vec3 v_to_light;
in vec3 v_to_eye;
in vec2 v_uv;

uniform sampler2D u_albedo_alpha;  // sRGB texture: decoded to linear by GL
uniform sampler2D u_normal_gloss;  // averaged tangent normal, gloss
uniform float u_ambient;
uniform float u_diffuse;
uniform float u_specular;
uniform float u_shininess;
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
  vec3 light = normalize(to_light);
  vec3 eye = normalize(to_eye);
  float len = max(length(normal_gloss.xyz), 1e-4);
  vec3 normal = normal_gloss.xyz / len;
  float toksvig = len / (len + u_shininess * (1.0 - len));
  float exponent = max(toksvig * u_shininess, 1.0);
  float horizon = clamp(light.z * 4.0, 0.0, 1.0);
  float lambert = max(dot(normal_gloss.xyz, light), 0.0);
  vec3 half_vector = normalize(light + eye);
  float facing = dot(normal, light) > 0.0 ? 1.0 : 0.0;
  float highlight = facing * (exponent + 2.0) / (u_shininess + 2.0) *
                    pow(max(dot(normal, half_vector), 0.0), exponent);
  float attenuation = u_point_light > 0.5
      ? u_reference_distance * u_reference_distance / dot(to_light, to_light)
      : 1.0;
  vec3 direct = u_light_colour * (attenuation * horizon);
  vec3 colour = albedo.rgb * (u_ambient + u_diffuse * lambert * direct) +
                u_specular * normal_gloss.a * highlight * direct;
  fragment = vec4(u_encode_srgb ? srgb_encode(colour) : colour, albedo.a);
}
