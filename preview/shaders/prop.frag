#version 300 es
// Matte: Lambert under the knit view's light and a soft ambient, no
// shadows (the cloth is the subject).
precision mediump float;

in vec3 v_position;
in vec3 v_normal;

uniform vec4 u_light;   // position (w = 1) or direction toward the light (w = 0)
uniform vec3 u_colour;  // linear
uniform bool u_encode_srgb;

out vec4 fragment;

void main() {
  vec3 n = normalize(v_normal);
  vec3 toward = normalize(u_light.xyz - u_light.w * v_position);
  float lit = 0.3 + 0.7 * max(dot(n, toward), 0.0);
  vec3 colour = clamp(u_colour * lit, 0.0, 1.0);
  fragment = vec4(u_encode_srgb ? pow(colour, vec3(1.0 / 2.2)) : colour, 1.0);
}
