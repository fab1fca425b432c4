#version 300 es
// The scan as the far level (scan_surface.h): the stitch mesh, its (u, v)
// the scan's tile at physical size, the light and eye carried into each
// vertex's tangent space as swatch.vert carries them.

layout(location = 0) in vec3 a_position;  // world, mm
layout(location = 1) in vec3 a_normal;    // unit, the cloth's front
layout(location = 2) in vec3 a_tangent;   // unit, along the courses, normal to a_normal
layout(location = 3) in vec2 a_uv;        // tiles
layout(location = 4) in vec3 a_ambient_front;  // the environment's light, a share of the albedo
layout(location = 5) in vec3 a_ambient_back;

uniform mat4 u_view_projection;
uniform vec3 u_eye;        // world position
uniform vec4 u_light;      // world: position (w = 1) or direction to the light (w = 0)
uniform float u_lift_mm;   // toward the eye: over the yarns' own depth where they lie beneath
uniform float u_yarn_px_mm;  // the yarn's width (mm) times pixels per mm at unit clip w

out vec3 v_to_light;  // tangent space
out vec3 v_to_eye;
out vec2 v_uv;
out vec3 v_ambient_front;
out vec3 v_ambient_back;
out float v_yarn_px;

void main() {
  vec3 bitangent = cross(a_normal, a_tangent);
  mat3 to_tangent = transpose(mat3(a_tangent, bitangent, a_normal));
  v_to_light = to_tangent * (u_light.xyz - u_light.w * a_position);
  v_to_eye = to_tangent * (u_eye - a_position);
  v_uv = a_uv;
  v_ambient_front = a_ambient_front;
  v_ambient_back = a_ambient_back;
  vec3 lifted = a_position + u_lift_mm * normalize(u_eye - a_position);
  gl_Position = u_view_projection * vec4(lifted, 1.0);
  v_yarn_px = u_yarn_px_mm / max(gl_Position.w, 1e-6);
}
