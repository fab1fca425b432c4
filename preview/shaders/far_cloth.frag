#version 300 es
// The repeat's texel, premultiplied linear colour and coverage, averaged
// over the pixel's footprint by the mipmaps. Drawn alone it is blended over what lies beneath
// (GL_ONE, GL_ONE_MINUS_SRC_ALPHA); over yarns still drawn at the near
// level it takes over as the yarn narrows from u_fade_px.x to u_fade_px.y
// pixels, the cloth over the cleared background cross-faded with them.
precision highp float;

in vec2 v_repeat;
in float v_yarn_px;

uniform sampler2D u_repeat_texture;
uniform vec2 u_fade_px;       // the far level from none (x) to all (y), x > y
uniform bool u_over_yarns;    // the near level's yarns are drawn beneath
uniform vec3 u_background;    // linear, what the bake's gaps show
uniform bool u_encode_srgb;

out vec4 fragment;

vec3 srgb_encode(vec3 linear) {
  linear = clamp(linear, 0.0, 1.0);
  vec3 low = 12.92 * linear;
  vec3 high = 1.055 * pow(linear, vec3(1.0 / 2.4)) - 0.055;
  return mix(high, low, vec3(lessThanEqual(linear, vec3(0.0031308))));
}

void main() {
  // Four taps a half pixel apart, each from the level a half pixel calls
  // for (bias -1): a box over the pixel, as a frame drawn finer and
  // box-filtered is. One trilinear tap is a tent two pixels wide (its
  // level's texels are a pixel, then interpolated) and blurs the stitches
  // away; one tap a level finer aliases (the dolly steps 2.9 %).
  vec2 dx = 0.25 * dFdx(v_repeat), dy = 0.25 * dFdy(v_repeat);
  vec4 texel = 0.25 * (texture(u_repeat_texture, v_repeat - dx - dy, -1.0) +
                       texture(u_repeat_texture, v_repeat + dx - dy, -1.0) +
                       texture(u_repeat_texture, v_repeat - dx + dy, -1.0) +
                       texture(u_repeat_texture, v_repeat + dx + dy, -1.0));
  vec3 colour = texel.rgb;
  float alpha = texel.a;
  if (u_over_yarns || u_encode_srgb) {
    float far = 1.0 - smoothstep(u_fade_px.y, u_fade_px.x, v_yarn_px);
    if (u_over_yarns && far <= 0.0) discard;
    alpha = u_over_yarns ? far : 1.0;
    colour = alpha * (texel.rgb + (1.0 - texel.a) * u_background);
    if (u_encode_srgb) colour = srgb_encode(colour);
  }
  fragment = vec4(colour, alpha);
}
