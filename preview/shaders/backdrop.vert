#version 300 es
// The whole viewport as one triangle (no vertex buffer: from gl_VertexID),
// at the far plane.

void main() {
  vec2 corner = vec2(float((gl_VertexID & 1) * 4 - 1), float((gl_VertexID & 2) * 2 - 1));
  gl_Position = vec4(corner, 1.0, 1.0);
}
