#version 300 es
// The light drawn as a small sphere (VirTex: feedback on where it is).

layout(location = 0) in vec3 a_position;  // unit sphere

uniform mat4 u_view_projection;
uniform vec3 u_centre;
uniform float u_radius;

out vec3 v_normal;

void main() {
  v_normal = a_position;
  gl_Position = u_view_projection * vec4(u_centre + u_radius * a_position, 1.0);
}
