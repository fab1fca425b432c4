#version 300 es
// The repeat's premultiplied linear colour and coverage averaged over the
// pixel's footprint, from its summed-area table (repeat_texture.h). Drawn
// alone it is blended over what lies beneath (GL_ONE,
// GL_ONE_MINUS_SRC_ALPHA); over yarns still drawn at the near
// level it takes over as the yarn narrows from u_fade_px.x to u_fade_px.y
// pixels, the cloth over the cleared background cross-faded with them.
precision highp float;

in vec2 v_repeat;
in vec2 v_grid;
in float v_yarn_px;

uniform highp sampler2D u_area_table;  // repeat_area_table()
uniform vec2 u_area_texels;             // the repeat's size in the table's level
uniform vec4 u_area_mean;               // what the table's sums have taken off
uniform vec3 u_shade[9];                // FarCloth::set_shade: 3 x 3, row by row
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

// The area table at `p` (its texels, within [0, 2W] x [0, 2H]): bilinear
// between its entries, which is the exact sum of the texels (each a
// constant square) below and left of `p`.
vec4 area_sum(vec2 p) {
  vec2 floor_p = floor(p);
  vec2 t = p - floor_p;
  ivec2 i = ivec2(floor_p);
  ivec2 j = min(i + 1, ivec2(2.0 * u_area_texels));
  return mix(mix(texelFetch(u_area_table, i, 0), texelFetch(u_area_table, ivec2(j.x, i.y), 0), t.x),
             mix(texelFetch(u_area_table, ivec2(i.x, j.y), 0), texelFetch(u_area_table, j, 0), t.x),
             t.y);
}

// The mean over the box about `centre` (repeats) reaching `reach` texels
// each way: at most half a repeat (a repeat's mean is the mean of any
// more), so that, its centre in the first tile, it never leaves the 2x2.
vec4 box_mean(vec2 centre, vec2 reach) {
  reach = min(reach, 0.5 * u_area_texels);
  vec2 middle = fract(centre) * u_area_texels;
  middle += vec2(lessThan(middle - reach, vec2(0.0))) * u_area_texels;
  vec2 low = middle - reach, high = middle + reach;
  vec4 sum = area_sum(high) - area_sum(vec2(low.x, high.y)) - area_sum(vec2(high.x, low.y)) +
             area_sum(low);
  vec2 sides = max(high - low, vec2(1e-3));
  return sum / (sides.x * sides.y) + u_area_mean;
}

// The shade grid's factor at `grid` (0 to 1 over the mesh), bilinear.
vec3 shade_at(vec2 grid) {
  vec2 at = clamp(grid, 0.0, 1.0) * 2.0;
  ivec2 low = min(ivec2(at), ivec2(1));
  vec2 t = at - vec2(low);
  int k = low.y * 3 + low.x;
  return mix(mix(u_shade[k], u_shade[k + 1], t.x), mix(u_shade[k + 3], u_shade[k + 4], t.x), t.y);
}

void main() {
  // A frame drawn finer and box-filtered is what the far level must equal,
  // so each pixel takes the mean over its footprint in the repeat (the
  // parallelogram of its derivatives), from the area table over the
  // footprint's bounding box. At least a texel wide: a box a texel wide
  // over texels held constant is the bilinear filter, so a texture seen
  // magnified is interpolated, not blocky. Mipmaps did worse: one
  // trilinear tap is a tent two pixels wide (its level's texels are a
  // pixel, then interpolated) that blurs the stitches away, one tap a
  // level finer aliases, and against the twill's 4x reference four taps
  // half a pixel apart left an RMSE of 13.4, sixteen 10.5 (at three times
  // the cost), the table 9.9. One path for every pixel, no branch:
  // llvmpipe runs both sides of a branch its pixels disagree on.
  vec2 edge_x = dFdx(v_repeat) * u_area_texels, edge_y = dFdy(v_repeat) * u_area_texels;
  vec2 bounds = abs(edge_x) + abs(edge_y);
  float area = abs(edge_x.x * edge_y.y - edge_x.y * edge_y.x);
  vec2 sides = bounds * sqrt(area / max(bounds.x * bounds.y, 1e-12));
  vec4 texel = box_mean(v_repeat, max(0.5 * sides, vec2(0.5)));
  vec3 colour = texel.rgb * shade_at(v_grid);
  texel.rgb = colour;
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
