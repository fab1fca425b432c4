#version 300 es
// The swatch patch: light and eye vectors carried into each vertex's
// tangent space (VirTex's vertex program), interpolated unnormalised so a
// flat patch gets them exact at every pixel.

layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec3 a_tangent;
layout(location = 3) in vec3 a_bitangent;
layout(location = 4) in vec2 a_uv;

uniform mat4 u_model;           // a rotation: tangent frames turn with it
uniform mat4 u_view_projection;
uniform vec4 u_eye;             // world: position (w = 1) or direction to the viewer (w = 0)
uniform vec4 u_light;           // world: position (w = 1) or direction to the light (w = 0)

out vec3 v_to_light;  // tangent space
out vec3 v_to_eye;
out vec2 v_uv;

void main() {
  vec4 world = u_model * vec4(a_position, 1.0);
  mat3 turn = mat3(u_model);
  // Rows of the world -> tangent matrix.
  mat3 to_tangent = transpose(mat3(turn * a_tangent, turn * a_bitangent, turn * a_normal));
  v_to_light = to_tangent * (u_light.xyz - u_light.w * world.xyz);
  v_to_eye = to_tangent * (u_eye.xyz - u_eye.w * world.xyz);
  v_uv = a_uv;
  gl_Position = u_view_projection * world;
}
