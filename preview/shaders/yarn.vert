#version 300 es
// Yarns as camera-facing strips of the yarn's width
// (huang2025-realtime-knit-deformation-rendering.txt, 5.2), expanded here
// from the centreline with no geometry shader: one vertex per point, drawn
// as a triangle strip whose vertices alternate sides, so each point is
// uploaded once and shaded once. The same shader draws the shadow map (the
// "eye" then is the light) and, with LINES, the far view's lines: ribbons
// at least a pixel wide (triangles, not GL lines: llvmpipe's multisampled
// lines drop segments shorter than a pixel, and a far yarn's are).

// One buffer of points, read three times at one point's offset apart.
layout(location = 0) in vec4 a_previous;     // xyz: position (mm), w: arc length along its yarn
layout(location = 1) in vec4 a_point;
layout(location = 2) in vec4 a_next;
layout(location = 3) in vec4 a_normal_lift;  // the cloth's normal, the yarn's lift
layout(location = 4) in vec3 a_colour;       // linear

uniform mat4 u_view_projection;
uniform vec4 u_eye;  // position (w = 1) or direction toward the viewer (w = 0)
uniform float u_radius;
uniform float u_half_pixel;  // LINES: half a pixel in mm, per mm from the eye

out vec3 v_position;  // on the strip, through the centreline
out float v_across;   // -1 to 1 across the strip
out vec3 v_tangent;
out vec3 v_cloth_normal;
out float v_lift;
out vec3 v_colour;
out float v_arc;

void main() {
  // Arc length rises along a yarn: a neighbour that does not rise belongs
  // to another yarn (or is the buffer's padding), and the tangent is taken
  // one-sided.
  vec3 behind = a_previous.w < a_point.w ? a_previous.xyz : a_point.xyz;
  vec3 ahead = a_next.w > a_point.w ? a_next.xyz : a_point.xyz;
  vec3 tangent = ahead - behind;
  tangent = dot(tangent, tangent) > 0.0 ? normalize(tangent) : vec3(1.0, 0.0, 0.0);
  vec3 to_eye = u_eye.xyz - u_eye.w * a_point.xyz;
  vec3 side = cross(tangent, to_eye);
  if (dot(side, side) <= 1e-12 * dot(to_eye, to_eye))  // seen end-on
    side = cross(tangent, abs(tangent.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0));
  side = normalize(side);
  float across = (gl_VertexID & 1) == 0 ? -1.0 : 1.0;
#ifdef LINES
  float half_width = max(u_radius, u_half_pixel * length(to_eye));
#else
  float half_width = u_radius;
#endif
  v_position = a_point.xyz + across * half_width * side;
  v_across = across;
  v_tangent = tangent;
  v_cloth_normal = a_normal_lift.xyz;
  v_lift = a_normal_lift.w;
  v_colour = a_colour;
  v_arc = a_point.w;
  gl_Position = u_view_projection * vec4(v_position, 1.0);
}
