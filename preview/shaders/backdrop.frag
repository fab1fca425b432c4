#version 300 es
// The background behind yarns whose coverage was accumulated front to back
// (yarn_renderer.cpp's far frames): drawn last with the same saturating
// blend, it fills what the yarns left uncovered.
precision mediump float;

uniform vec3 u_colour;  // linear, or sRGB encoded already for a linear framebuffer

out vec4 fragment;

void main() {
  fragment = vec4(u_colour, 1.0);
}
