// The fibres' lighting, shared by yarn.vert (the far view's colour, made per
// vertex) and yarn.frag (the near view's, per fragment); inserted into both
// after their defines. yarn_shading.cpp's shade_fragment() is its CPU twin,
// keep the two in step: the ellipse's normal at the strip coordinate,
// tilted across the plies; the fibres turned by their tilt; the three lobes
// of huang2025-realtime-knit-deformation-rendering.txt eq. 7 (Kajiya-Kay
// diffuse D, white reflection R, coloured transmission TT, longitudinal
// Gaussians in the half angle times azimuthal terms) with eq. 8's dual
// scattering approximated (the local gain and the global wrap); the
// environment's light interpolated quadratically across from three values.
precision highp float;

// FibreShading
uniform float u_diffuse;
uniform float u_wrap;
uniform vec3 u_reflection;    // weight, shift, width
uniform vec3 u_transmission;  // weight, shift, width
uniform float u_local_scattering;
uniform float u_global_scattering;
uniform float u_ply_relief;

float fibre_lobe(float half_angle, float shift, float width) {
  float d = half_angle - shift;
  return exp(-d * d / (2.0 * width * width));
}

vec3 local_gain(vec3 albedo) {
  vec3 bounce = u_local_scattering * min(albedo, vec3(0.98));
  return vec3(1.0) + bounce / (vec3(1.0) - bounce);
}

// `surface`: the slice's ply offset, fibre tilt's sine and light.
vec3 shade_fibres(float across, vec3 across_normal, vec3 facing_normal, vec3 tangent,
                  vec3 ply_across, vec3 surface, vec3 to_light, vec3 to_eye, vec3 albedo,
                  vec3 environment_left, vec3 environment_middle, vec3 environment_right,
                  vec3 direct_light) {
  float a = clamp(across, -1.0, 1.0);
  vec3 normal = normalize(a * across_normal + sqrt(max(1.0 - a * a, 0.0)) * facing_normal);
  normal = normalize(normal + u_ply_relief * surface.x * ply_across);
  float tilt_sin = surface.y;
  float tilt_cos = sqrt(max(1.0 - tilt_sin * tilt_sin, 0.0));
  vec3 fibre = normalize(tilt_cos * tangent + tilt_sin * cross(normal, tangent));
  vec3 light = normalize(to_light);
  vec3 eye = normalize(to_eye);
  float sin_in = dot(fibre, light);
  float sin_out = dot(fibre, eye);
  float kajiya_kay = sqrt(max(1.0 - sin_in * sin_in, 0.0));
  float half_angle = 0.5 * (sin_in + sin_out);
  float reflection = fibre_lobe(half_angle, u_reflection.y, u_reflection.z);
  float transmission = fibre_lobe(half_angle, u_transmission.y, u_transmission.z);
  // Azimuth between light and eye about the fibre: R faces back, TT through.
  vec3 light_round = light - sin_in * fibre;
  vec3 eye_round = eye - sin_out * fibre;
  float cos_azimuth = dot(light_round, eye_round) *
                      inversesqrt(max(dot(light_round, light_round) * dot(eye_round, eye_round), 1e-8));
  float toward = 0.5 + 0.5 * cos_azimuth;
  float through = 0.5 - 0.5 * cos_azimuth;
  through *= through;
  through *= through;
  float normal_light = dot(normal, light);
  // R off the fibres' surface sees the plain terminator; D, scattered
  // inside, wraps further round the lighter the yarn (the global part).
  float surface_facing = clamp((normal_light + u_wrap) / (1.0 + u_wrap), 0.0, 1.0);
  vec3 wrap = u_wrap + (1.0 - u_wrap) * u_global_scattering * albedo;
  vec3 facing = clamp((normal_light + wrap) / (1.0 + wrap), 0.0, 1.0);
  vec3 lit = facing * albedo * local_gain(albedo) * (u_diffuse * kajiya_kay) +
             surface_facing * (u_reflection.x * reflection * toward) +
             albedo * (u_transmission.x * transmission * through);
  vec3 environment = environment_middle + (0.5 * a) * (environment_right - environment_left) +
                     (a * a) * (0.5 * (environment_right + environment_left) - environment_middle);
  return surface.z * (environment + direct_light * lit);
}
