#version 300 es
// The neural far level of a weave (issue 31, woven_far_cloth.h): the stitch
// mesh, its (u, v) in repeats of the weave, and the cloth's frame at each
// vertex (along the wefts, the model's +x; the front, +z), for
// woven_decoder.frag's query per pixel (QUERIES_FROM_MESH).

layout(location = 0) in vec3 a_position;  // world, mm
layout(location = 1) in vec2 a_repeat;    // face coordinates over the weave's repeat
layout(location = 2) in vec3 a_across;    // unit, along the wefts (across the warps)
layout(location = 3) in vec3 a_normal;    // unit, the cloth's front

uniform mat4 u_view_projection;
uniform float u_yarn_px_mm;  // the yarn's width (mm) times pixels per mm at unit clip w

out vec3 v_position;
out vec2 v_repeat;
out vec3 v_across;
out vec3 v_normal;
out float v_yarn_px;  // the yarn's width here, pixels (the levels' cross-fade)

void main() {
  v_position = a_position;
  v_repeat = a_repeat;
  v_across = a_across;
  v_normal = a_normal;
  gl_Position = u_view_projection * vec4(a_position, 1.0);
  v_yarn_px = u_yarn_px_mm / max(gl_Position.w, 1e-6);
}
