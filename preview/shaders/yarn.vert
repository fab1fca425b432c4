#version 300 es
// Yarns as camera-facing strips as wide as their elliptical cross-section
// looks from the eye (huang2025-realtime-knit-deformation-rendering.txt,
// 5.2), expanded here from the centreline with no geometry shader: one
// vertex per point, drawn as a triangle strip whose vertices alternate
// sides. yarn_shading.cpp is the CPU twin of these lines (and of
// yarn_fibres.glsl, inserted above); keep them in step. Per vertex,
// because a vertex is shared by many fragments: the strip's frame, the
// environment's light at three points across it, the shadow
// (chen2003-lumislice-knitwear.txt 5.2.1 also tests its shadow map only at
// the slices' vertices), the level of detail, and the far view's colour:
// the fibres' light averaged across the yarn with the slice's mean (the
// coarsest lumislice of chen2003 5.2.2), which is all a yarn a few pixels
// wide shows. A yarn narrower than u_min_half_px is drawn that wide and
// that much transparent.
//
// DEPTH_PASS: the shadow map's strips, facing the light (u_eye).
// HALO: the flyaway fibres' ribbons either side of the core, one instance
// a side (huang2025 4.4 draws flyaways in a pass of their own).
// SHADOWS: the shadow map is sampled (else the statistical shadows alone).

// One buffer of points, read three times at one point's offset apart.
layout(location = 0) in vec4 a_previous;     // xyz: position (mm), w: arc length along its yarn
layout(location = 1) in vec4 a_point;
layout(location = 2) in vec4 a_next;
layout(location = 3) in vec4 a_normal_lift;  // the cloth's normal, the yarn's lift
layout(location = 4) in vec4 a_colour_seed;  // sRGB colour, the yarn's random phase

uniform mat4 u_view_projection;
uniform vec4 u_eye;  // position (w = 1) or direction toward the viewer (w = 0)
uniform float u_radius;
uniform float u_flatness;

#ifndef DEPTH_PASS
uniform float u_focal_px;     // pixels per mm at unit clip w
uniform float u_min_half_px;  // the narrowest half strip drawn
uniform float u_halo;         // the slice's halo, in radii
uniform vec2 u_halo_fade_px;  // yarn widths over which the halo grows in
uniform float u_period;       // the slice's length along the yarn, mm
uniform float u_turn_scale;   // twist pitch / period
uniform float u_slice_phase;  // added to every yarn's phase (KnitFrame::slice_phase)
uniform float u_ply_slant_sin;
uniform vec4 u_light;  // position (w = 1) or direction toward the light (w = 0)
uniform float u_reference_distance;
uniform vec3 u_environment[9];  // order-2 harmonics, environment_light.h's order
// FibreShading
uniform float u_environment_scale;
uniform float u_environment_fibre;
uniform float u_environment_sheen;
uniform float u_crossing_occlusion;
uniform float u_shadow_density;
uniform vec3 u_light_colour;
uniform vec3 u_albedo_gain;  // every yarn's colour times this (YarnRenderer::set_colour_match)
uniform vec3 u_mean_surface;  // the slice's mean: ply offset, tilt's sine, light
uniform vec2 u_far_px;        // yarn widths over which the near view's detail grows in
uniform float u_prefilter_px;      // FAR: the strip's widening either side
uniform vec2 u_prefilter_fade_px;  // FAR: yarn widths over which it fades out
uniform float u_soft_edges;        // FAR: 1 blended (prefiltered edges), 0 opaque (the samples' edges)
#ifdef SHADOWS
uniform highp sampler2DShadow u_shadow_map;
uniform mat4 u_shadow_view_projection;
uniform float u_shadow_bias;      // in the map's depth units
uniform float u_shadow_extent;    // the part of the map drawn into, as a fraction of it
uniform float u_shadow_strength;  // the map's share against the statistical shadows
#endif

out float v_across;  // strip coordinate: -1 to 1 over the core
out vec2 v_uv;       // in the slice
out vec3 v_tangent;
out vec3 v_across_normal;
out vec3 v_facing_normal;
out vec3 v_ply_across;
out vec3 v_to_light;
out vec3 v_to_eye;
out vec3 v_albedo;
out vec3 v_environment_left;
out vec3 v_environment_middle;
out vec3 v_environment_right;
out vec3 v_direct;
out float v_coverage;
out vec3 v_far_colour;
out float v_detail;
out vec4 v_far_coverage;  // FAR: distance from the centreline, half width, spread (px), softness
#endif

const float kPi = 3.14159265359;

vec3 normal_to(vec3 v) {
  return normalize(cross(v, abs(v.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0)));
}

vec3 across_of(vec3 v, vec3 t, vec3 fallback) {
  vec3 rest = v - dot(v, t) * t;
  return dot(rest, rest) > 1e-12 * max(dot(v, v), 1e-30) ? normalize(rest) : fallback;
}

#ifndef DEPTH_PASS
vec3 srgb_decode(vec3 encoded) {
  vec3 low = encoded / 12.92;
  vec3 high = pow((encoded + 0.055) / 1.055, vec3(2.4));
  return mix(high, low, vec3(lessThanEqual(encoded, vec3(0.04045))));
}

vec3 harmonics_sum(vec3 w, vec3 bands) {
  vec3 sum = u_environment[0] * (0.282095 * bands.x);
  sum += (u_environment[1] * (0.488603 * w.y) + u_environment[2] * (0.488603 * w.z) +
          u_environment[3] * (0.488603 * w.x)) * bands.y;
  sum += (u_environment[4] * (1.092548 * w.x * w.y) + u_environment[5] * (1.092548 * w.y * w.z) +
          u_environment[6] * (0.315392 * (3.0 * w.z * w.z - 1.0)) +
          u_environment[7] * (1.092548 * w.x * w.z) +
          u_environment[8] * (0.546274 * (w.x * w.x - w.y * w.y))) * bands.z;
  return sum;
}

vec3 environment_shading(vec3 normal, vec3 tangent, vec3 eye, vec3 albedo) {
  vec3 diffuse = (1.0 - u_environment_fibre) * max(harmonics_sum(normal, vec3(1.0, 2.0 / 3.0, 0.25)), 0.0) +
                 u_environment_fibre * max(harmonics_sum(tangent, vec3(1.0, 0.0, -0.125)), 0.0);
  vec3 mirror = 2.0 * dot(normal, eye) * normal - eye;
  vec3 sheen = max(harmonics_sum(mirror, vec3(1.0)), 0.0);
  return u_environment_scale * (albedo * local_gain(albedo) * diffuse + u_environment_sheen * sheen);
}
#endif

void main() {
  // Arc length rises along a yarn: a neighbour that does not rise belongs
  // to another yarn (or is the buffer's padding), and the tangent is taken
  // one-sided.
  vec3 behind = a_previous.w < a_point.w ? a_previous.xyz : a_point.xyz;
  vec3 ahead = a_next.w > a_point.w ? a_next.xyz : a_point.xyz;
  vec3 tangent = ahead - behind;
  tangent = dot(tangent, tangent) > 0.0 ? normalize(tangent) : vec3(1.0, 0.0, 0.0);
  vec3 to_eye = u_eye.xyz - u_eye.w * a_point.xyz;
  vec3 facing = across_of(to_eye, tangent, normal_to(tangent));
  vec3 side = cross(tangent, facing);
  // The cross-section's axes: `up` along the cloth's normal, `in_plane` across.
  vec3 up = across_of(a_normal_lift.xyz, tangent, facing);
  vec3 in_plane = cross(tangent, up);
  float flattening = clamp(u_flatness, 0.05, 1.0);
  float view_in = dot(facing, in_plane);
  float view_up = dot(facing, up);
  float half_width = u_radius * sqrt(view_up * view_up + flattening * flattening * view_in * view_in);
  float across = (gl_VertexID & 1) == 0 ? -1.0 : 1.0;

#ifdef DEPTH_PASS
  gl_Position = u_view_projection * vec4(a_point.xyz + across * half_width * side, 1.0);
#else
  vec4 centre = u_view_projection * vec4(a_point.xyz, 1.0);
  float px_per_mm = u_focal_px / max(centre.w, 1e-6);
  float half_px = half_width * px_per_mm;
  float drawn = max(half_px, u_min_half_px) / px_per_mm;  // mm
  v_coverage = half_px / max(half_px, u_min_half_px);
#if defined(FAR)
  // Widened by the prefilter's reach: yarn.frag's coverage is the yarn's
  // width convolved with a tent that wide. Wider still as the yarn thins
  // further: a yarn a third of a pixel wide sits in a stitch under two
  // pixels, whose structure no pixel resolves. The coverage is worked out
  // at the pixel's centre, so the tent takes in the pixel's own width too
  // (a box of a pixel has a tent's spread at half-width sqrt(1/2); spreads
  // add): the samples see no edge, and as the prefilter fades out the
  // strip is what 4x MSAA would make of the yarn alone.
  float prefilter = u_prefilter_px * clamp(u_prefilter_fade_px.x / (2.5 * half_px), 1.0, 1.25) *
                    (1.0 - smoothstep(u_prefilter_fade_px.x, u_prefilter_fade_px.y, 2.0 * half_px));
  // Soft edges grow in with the prefilter, over its whole fade (a quick
  // switch to the samples' hard edges shows as a step as a view recedes):
  // without it the samples draw the yarn's own edges, as the opaque far
  // frames do.
  float soft = u_soft_edges * clamp(prefilter, 0.0, 1.0);
  float spread = soft * sqrt(prefilter * prefilter + 0.5);
  vec3 position = a_point.xyz + across * ((half_px + spread) / px_per_mm) * side;
  v_far_coverage = vec4(across * (half_px + spread), half_px, spread, soft);
#elif defined(HALO)
  // Inner edge on the core's, outer at the halo's reach; left, then right.
  float halo = u_halo * smoothstep(u_halo_fade_px.x, u_halo_fade_px.y, 2.0 * half_px);
  float sign_side = gl_InstanceID == 0 ? -1.0 : 1.0;
  bool outer = (gl_VertexID & 1) == 1;
  across = sign_side * (outer ? 1.0 + halo : 1.0);
  vec3 position = a_point.xyz + sign_side * (outer ? max(half_width * (1.0 + halo), drawn) : drawn) * side;
  v_coverage = 1.0;
#else
  vec3 position = a_point.xyz + across * drawn * side;
#endif
  gl_Position = u_view_projection * vec4(position, 1.0);
  v_across = across;
  float turn = (kPi / 2.0 - atan(view_up, view_in)) / (2.0 * kPi);
  v_uv = vec2(0.5 + 0.5 * across / (1.0 + u_halo),
              a_point.w / u_period + turn * u_turn_scale + a_colour_seed.w + u_slice_phase);

  // The ellipse's normals (yarn_shading.cpp's strip_frame()).
  vec2 facing_circle = normalize(vec2(view_in, view_up / flattening));
  vec2 side_circle = vec2(facing_circle.y, -facing_circle.x);
  v_across_normal = side_circle.x * in_plane + side_circle.y / flattening * up;
  v_facing_normal = facing_circle.x * in_plane + facing_circle.y / flattening * up;
  v_tangent = tangent;
  float slant_cos = sqrt(max(1.0 - u_ply_slant_sin * u_ply_slant_sin, 0.0));
  v_ply_across = slant_cos * side - u_ply_slant_sin * tangent;

  vec3 albedo = min(srgb_decode(a_colour_seed.rgb) * u_albedo_gain, vec3(1.0));
  v_albedo = albedo;
  v_to_eye = u_eye.xyz - u_eye.w * position;
  vec3 to_light = u_light.xyz - u_light.w * a_point.xyz;
  v_to_light = u_light.xyz - u_light.w * position;
  vec3 light = normalize(to_light);

  float crossing = 1.0 - u_crossing_occlusion * (1.0 - min(abs(a_normal_lift.w), 1.0));
  vec3 eye = normalize(to_eye);
  vec3 left = normalize(-v_across_normal);
  vec3 middle = normalize(v_facing_normal);
  vec3 right = normalize(v_across_normal);
  v_environment_left = crossing * environment_shading(left, tangent, eye, albedo);
  v_environment_middle = crossing * environment_shading(middle, tangent, eye, albedo);
  v_environment_right = crossing * environment_shading(right, tangent, eye, albedo);

  // Shadows: statistical where yarns are too small for the map (yarn_shading.cpp).
  float c = dot(normalize(a_normal_lift.xyz), light);
  float on_top = clamp(c >= 0.0 ? a_normal_lift.w : -a_normal_lift.w, -1.0, 1.0);
  float tangent_of_slant = sqrt(max(1.0 - c * c, 0.0)) / max(abs(c), 0.05);
  float shadow = exp(-u_shadow_density * 0.5 * (1.0 - on_top) * tangent_of_slant);
#ifdef SHADOWS
  {
    // The map holds its yarns' strips through their centres: look it up at
    // the ellipse's point nearest the light (toward_light_surface()).
    float a = u_radius, b = flattening * u_radius;
    float l_in = dot(light, in_plane), l_up = dot(light, up);
    float reach = sqrt(a * a * l_in * l_in + b * b * l_up * l_up);
    vec3 surface = a_point.xyz;
    if (reach > 1e-9) surface += (a * a * l_in * in_plane + b * b * l_up * up) / reach;
    vec4 clip = u_shadow_view_projection * vec4(surface, 1.0);
    vec3 map = clip.xyz / clip.w * 0.5 + 0.5;
    float lit = texture(u_shadow_map, vec3(map.xy * u_shadow_extent, map.z - u_shadow_bias));
    shadow = mix(shadow, lit, u_shadow_strength);
  }
#endif
  float attenuation = u_light.w > 0.5
      ? u_reference_distance * u_reference_distance / dot(to_light, to_light)
      : 1.0;
  v_direct = (attenuation * crossing) * u_light_colour *
             (vec3(shadow) + (1.0 - shadow) * u_global_scattering * albedo);

  // The far view: the fibres' light at three points across (the middle
  // and either side), their mean.
  vec3 far = vec3(0.0);
  for (int i = -1; i <= 1; ++i)
    far += shade_fibres(float(i) * (2.0 / 3.0), v_across_normal, v_facing_normal, tangent,
                        v_ply_across, u_mean_surface, to_light, to_eye, albedo,
                        v_environment_left, v_environment_middle, v_environment_right, v_direct);
  v_far_colour = far / 3.0;
  v_detail = smoothstep(u_far_px.x, u_far_px.y, 2.0 * half_px);
#endif
}
