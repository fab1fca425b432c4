#version 300 es
// The repeat's texel, premultiplied linear colour and coverage, averaged
// over the pixel's footprint by the mipmaps (trilinear, anisotropic where
// the context offers it). Drawn alone it is blended over what lies beneath
// (GL_ONE, GL_ONE_MINUS_SRC_ALPHA); over yarns still drawn at the near
// level it takes over as the yarn narrows from u_fade_px.x to u_fade_px.y
// pixels, the cloth over the cleared background cross-faded with them.
precision highp float;

in vec2 v_repeat;
in float v_yarn_px;

uniform sampler2D u_repeat_texture;
// A trilinear tap's level has texels a pixel wide, then interpolated: a
// tent two pixels wide that blurs the stitches away. A level finer keeps
// the tap about a pixel (far_level_test: stockinette's RMSE 15.7 -> 13.1).
uniform float u_lod_bias;
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
  vec4 texel = texture(u_repeat_texture, v_repeat, u_lod_bias);
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
