#version 300 es
// The neural far level's decoded pixels (woven_far_cloth.h), premultiplied
// linear colour and the far level's share, laid over the frame (blended
// GL_ONE, GL_ONE_MINUS_SRC_ALPHA). Decoded at a lower resolution, they are
// interpolated bilinearly (the silhouette soft by as much).
precision highp float;

uniform sampler2D u_decoded;
uniform vec2 u_viewport;  // the frame's size, pixels
uniform bool u_encode_srgb;

out vec4 fragment;

vec3 srgb_encode(vec3 linear) {
  linear = clamp(linear, 0.0, 1.0);
  vec3 low = 12.92 * linear;
  vec3 high = 1.055 * pow(linear, vec3(1.0 / 2.4)) - 0.055;
  return mix(high, low, vec3(lessThanEqual(linear, vec3(0.0031308))));
}

void main() {
  vec4 decoded = texture(u_decoded, gl_FragCoord.xy / u_viewport);
  if (decoded.a <= 0.0) discard;
  // A linear framebuffer (a window surface without sRGB): encoded here,
  // and blended in encoded values, as far_cloth.frag does.
  if (u_encode_srgb) decoded.rgb = decoded.a * srgb_encode(decoded.rgb / decoded.a);
  fragment = decoded;
}
