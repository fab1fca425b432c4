#version 300 es
// Yarn shading; yarn_shading.cpp is the CPU twin of these lines, keep the
// two in step. The strip coordinate gives the tube's normal, the fibres
// are lit as hair (Kajiya-Kay diffuse, shifted R and TRT lobes), darkened
// where the yarn passes between the layers (lift), in the ply grooves and
// along fibres, and shadowed by other yarns through the shadow map
// (chen2003-lumislice-knitwear.txt, 5.2.1: yarns shadow yarns). With
// LINES: the centre of the tube with the detail averaged, for the far view.
// SHADOWS, FIBRE_DETAIL and ENCODE_SRGB are defines, not uniforms: a
// software rasteriser runs both sides of a branch, so what is off must not
// be there at all.
precision highp float;

in vec3 v_position;
in float v_across;
in vec3 v_tangent;
in vec3 v_cloth_normal;
in float v_lift;
in vec3 v_colour;
in float v_arc;

uniform vec4 u_eye;    // position (w = 1) or direction toward the viewer (w = 0)
uniform vec4 u_light;  // position (w = 1) or direction toward the light (w = 0)
uniform float u_reference_distance;  // a point light's full-strength distance
uniform float u_radius;
uniform float u_helix_angle;
uniform int u_plies;
uniform float u_twist_pitch;
// FibreShading
uniform float u_ambient;
uniform float u_diffuse;
uniform float u_wrap;
uniform vec3 u_primary;    // weight, shift, exponent
uniform vec3 u_secondary;  // weight, shift, exponent
uniform float u_crossing_occlusion;
uniform float u_ply_groove;
uniform float u_striation;
uniform int u_fibres_per_ply;
uniform vec3 u_light_colour;

uniform float u_mean_detail;  // lines: what the detail averages to
uniform highp sampler2DShadow u_shadow_map;
uniform mat4 u_shadow_view_projection;
uniform float u_shadow_bias;   // in the map's depth units
uniform float u_shadow_extent;  // the part of the map drawn into, as a fraction of it
uniform float u_shadow_strength;  // fades with the tubes
uniform float u_alpha;         // the level-of-detail blend weight

out vec4 fragment;

const float kTwoPi = 6.28318530718;
const float kMeanGroove = 35.0 / 128.0;

#ifdef ENCODE_SRGB
vec3 srgb_encode(vec3 linear) {
  linear = clamp(linear, 0.0, 1.0);
  vec3 low = 12.92 * linear;
  vec3 high = 1.055 * pow(linear, vec3(1.0 / 2.4)) - 0.055;
  return mix(high, low, vec3(lessThanEqual(linear, vec3(0.0031308))));
}
#endif

uint hash(uint x) {  // Wellons' lowbias32
  x ^= x >> 16u;
  x *= 0x7feb352du;
  x ^= x >> 15u;
  x *= 0x846ca68bu;
  x ^= x >> 16u;
  return x;
}

float signed_noise(uint lattice) {
  return float(hash(lattice) >> 8u) / 16777215.0 * 2.0 - 1.0;
}

vec3 tube_facing(vec3 tangent, vec3 to_eye) {
  vec3 facing = to_eye - dot(to_eye, tangent) * tangent;
  if (dot(facing, facing) < 1e-12)
    facing = cross(tangent, abs(tangent.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0));
  return normalize(facing);
}

float fibre_detail(float around, float arc, float fibres_per_pixel) {
  int plies = max(u_plies, 1);
  int fibres_per_ply = max(u_fibres_per_ply, 1);
  float turns = fract(around / kTwoPi - (u_twist_pitch > 0.0 ? arc / u_twist_pitch : 0.0));
  float between = 0.5 - 0.5 * cos(kTwoPi * float(plies) * turns);
  float plies_per_pixel = fibres_per_pixel / float(fibres_per_ply);
  float ply_fade = clamp(2.0 - 2.0 * plies_per_pixel, 0.0, 1.0);
  float squared = between * between;
  float groove = kMeanGroove + (squared * squared - kMeanGroove) * ply_fade;
  int stripes = plies * fibres_per_ply;
  float stripe = turns * float(stripes);
  float lattice = floor(stripe);
  int below = int(lattice) % stripes;
  float a = signed_noise(uint(below));
  float b = signed_noise(uint((below + 1) % stripes));
  float noise = a + (b - a) * smoothstep(0.0, 1.0, stripe - lattice);
  float fibre_fade = clamp(2.0 - 2.0 * fibres_per_pixel, 0.0, 1.0);
  return (1.0 - u_ply_groove * groove) * (1.0 + u_striation * noise * fibre_fade);
}

float shifted_lobe(vec3 tangent, vec3 normal, float shift, float exponent, vec3 half_vector) {
  float along = dot(normalize(tangent + shift * normal), half_vector);
  return pow(max(1.0 - along * along, 0.0), exponent / 2.0);
}

#ifdef SHADOWS
// PCF: one comparison filtered bilinearly (four texels) by the sampler.
float light_reaching(vec3 surface) {
  vec4 clip = u_shadow_view_projection * vec4(surface, 1.0);
  // Inside: the map holds the bounds' sphere, drawn into its lower-left
  // u_shadow_extent.
  vec3 map = clip.xyz / clip.w * 0.5 + 0.5;
  float lit = texture(u_shadow_map, vec3(map.xy * u_shadow_extent, map.z - u_shadow_bias));
  return mix(1.0, lit, u_shadow_strength);
}
#endif

void main() {
  vec3 tangent = normalize(v_tangent);
  vec3 to_eye = u_eye.xyz - u_eye.w * v_position;
  vec3 facing = tube_facing(tangent, to_eye);
#ifdef LINES
  float across = 0.0;
#else
  float across = clamp(v_across, -1.0, 1.0);
#endif
  float depth_out = sqrt(1.0 - across * across);
  vec3 normal = across * cross(tangent, facing) + depth_out * facing;
  vec3 surface = v_position + u_radius * depth_out * facing;

  float detail = 1.0;
#ifdef FIBRE_DETAIL
#ifdef LINES
  detail = u_mean_detail;
#else
  {
    vec3 up = v_cloth_normal - dot(v_cloth_normal, tangent) * tangent;
    up = dot(up, up) > 1e-12 ? normalize(up) : facing;
    float around = atan(dot(normal, cross(tangent, up)), dot(normal, up));
    // Screen footprint of one fibre stripe, wider toward the silhouette.
    float mm_per_pixel = length(fwidth(v_position));
    float stripe_mm = kTwoPi * u_radius / float(max(u_plies, 1) * max(u_fibres_per_ply, 1));
    float fibres_per_pixel = mm_per_pixel / (stripe_mm * max(depth_out, 0.1));
    detail = fibre_detail(around, v_arc, fibres_per_pixel);
  }
#endif
#endif
  float light_scale = (1.0 - u_crossing_occlusion * (1.0 - min(abs(v_lift), 1.0))) * detail;

  vec3 fibre = cos(u_helix_angle) * tangent + sin(u_helix_angle) * cross(normal, tangent);
  vec3 to_light = u_light.xyz - u_light.w * surface;
  vec3 light = normalize(to_light);
  vec3 eye = normalize(to_eye);
  float facing_light = clamp((dot(normal, light) + u_wrap) / (1.0 + u_wrap), 0.0, 1.0);
  float along_light = dot(fibre, light);
  float kajiya_kay = sqrt(max(1.0 - along_light * along_light, 0.0));
  vec3 half_vector = normalize(light + eye);
  float primary = shifted_lobe(fibre, normal, u_primary.y, u_primary.z, half_vector);
  float secondary = shifted_lobe(fibre, normal, u_secondary.y, u_secondary.z, half_vector);
  float attenuation = u_light.w > 0.5
      ? u_reference_distance * u_reference_distance / dot(to_light, to_light)
      : 1.0;
#ifdef SHADOWS
  float shadow = light_reaching(surface);
#else
  float shadow = 1.0;
#endif
  float direct = attenuation * shadow * facing_light;
  vec3 lit = v_colour * u_diffuse * kajiya_kay + u_primary.x * primary +
             v_colour * u_secondary.x * secondary;
  vec3 colour = light_scale * (v_colour * u_ambient + u_light_colour * direct * lit);
#ifdef ENCODE_SRGB
  colour = srgb_encode(colour);
#endif
  fragment = vec4(colour, u_alpha);
}
