#version 300 es
// Glowing in the light's colour, a little darker toward its rim so it
// reads as a sphere.
precision mediump float;

in vec3 v_normal;

uniform vec3 u_colour;     // linear
uniform vec3 u_to_viewer;  // world direction toward the camera at the sphere
uniform bool u_encode_srgb;

out vec4 fragment;

void main() {
  float facing = max(dot(normalize(v_normal), u_to_viewer), 0.0);
  vec3 colour = clamp(u_colour * (0.55 + 0.45 * facing), 0.0, 1.0);
  fragment = vec4(u_encode_srgb ? pow(colour, vec3(1.0 / 2.2)) : colour, 1.0);
}
