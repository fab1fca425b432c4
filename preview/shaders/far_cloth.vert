#version 300 es
// The far level (issue 30): the stitch mesh, its (u, v) in repeats of the
// pattern, textured with one repeat drawn at the near level
// (repeat_texture.h).

layout(location = 0) in vec3 a_position;  // world, mm
layout(location = 1) in vec2 a_repeat;    // face coordinates over the repeat's faces
layout(location = 2) in vec2 a_grid;      // place on the shade grid, 0 to 1 over the mesh

uniform mat4 u_view_projection;
uniform float u_yarn_px_mm;  // the yarn's width (mm) times pixels per mm at unit clip w

out vec2 v_repeat;
out vec2 v_grid;
out float v_yarn_px;  // the yarn's width here, pixels: which level draws this patch

void main() {
  v_repeat = a_repeat;
  v_grid = a_grid;
  gl_Position = u_view_projection * vec4(a_position, 1.0);
  v_yarn_px = u_yarn_px_mm / max(gl_Position.w, 1e-6);
}
