#version 300 es
// A full-screen triangle from gl_VertexID: the woven decoder's pass has no
// geometry of its own (its inputs are per-pixel textures).
void main() {
  vec2 corner = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
  gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
}
