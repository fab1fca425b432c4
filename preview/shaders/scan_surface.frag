#version 300 es
// The scan as the far level (scan_surface.h): the swatch's own maps lit
// per pixel as the swatch is (surface_lighting.glsl, inserted before these
// lines), the Toksvig term widening the highlight where a mipmap level
// averaged the bumps away. Over yarns still drawn at the near level it
// takes over as the yarn narrows from u_fade_px.x to u_fade_px.y pixels,
// cross-faded with them (blending GL_ONE, GL_ONE_MINUS_SRC_ALPHA).

in vec3 v_to_light;
in vec3 v_to_eye;
in vec2 v_uv;
in vec3 v_ambient_front;
in vec3 v_ambient_back;
in float v_yarn_px;

uniform sampler2D u_albedo_alpha;  // sRGB texture: decoded to linear by GL
uniform sampler2D u_normal_gloss;  // averaged tangent normal, gloss
uniform vec3 u_light_colour;
uniform float u_point_light;         // 1: attenuate by distance
uniform float u_reference_distance;  // a point light's full-strength distance
uniform vec2 u_fade_px;              // the far level from none (x) to all (y), x > y
uniform bool u_over_yarns;           // the near level's yarns are drawn beneath
uniform bool u_encode_srgb;
// ScanSurface::set_light_response: the direct light's share by the light's
// cosine to the plane, at 0, 1/6, ..., 1, in place of Lambert's.
uniform bool u_responds;
uniform vec3 u_response[7];

out vec4 fragment;

vec3 srgb_encode(vec3 linear) {
  linear = clamp(linear, 0.0, 1.0);
  vec3 low = 12.92 * linear;
  vec3 high = 1.055 * pow(linear, vec3(1.0 / 2.4)) - 0.055;
  return mix(high, low, vec3(lessThanEqual(linear, vec3(0.0031308))));
}

void main() {
  float far = u_over_yarns ? 1.0 - smoothstep(u_fade_px.y, u_fade_px.x, v_yarn_px) : 1.0;
  if (far <= 0.0) discard;
  vec4 albedo_alpha = texture(u_albedo_alpha, v_uv);
  vec3 albedo = albedo_alpha.rgb;
  vec4 normal_gloss = texture(u_normal_gloss, v_uv);
  vec3 to_light = v_to_light;
  vec3 to_eye = v_to_eye;
  vec3 ambient = v_ambient_front;
  if (!gl_FrontFacing) {  // the back of the cloth: shaded as a mirror of the front
    to_light.z = -to_light.z;
    to_eye.z = -to_eye.z;
    ambient = v_ambient_back;
  }
  float attenuation = u_point_light > 0.5
      ? u_reference_distance * u_reference_distance / dot(to_light, to_light)
      : 1.0;
  vec3 colour;
  if (u_responds) {
    float at = clamp(normalize(to_light).z, 0.0, 1.0) * 6.0;
    int below = min(int(at), 5);
    vec3 share = mix(u_response[below], u_response[below + 1], at - float(below));
    colour = albedo * (ambient + u_diffuse * share * u_light_colour * attenuation);
  } else {
    colour = surface_lighting(albedo, normal_gloss, to_light, to_eye, ambient,
                              u_light_colour * attenuation);
  }
  // The alpha map's coverage (a chart's repeat shows its gaps; a scan's is 1).
  float cover = far * albedo_alpha.a;
  fragment = vec4(cover * (u_encode_srgb ? srgb_encode(colour) : colour), cover);
}
