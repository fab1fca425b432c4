#version 300 es
// The neural woven BSDF's decoder (chen2024 4.2-4.3) per pixel, the twin of
// cloth/woven_network.cpp's WovenNetwork::decode: one-blob footprint ->
// spatial fusion -> angular decoder -> C_warp, C_weft, g(S_warp), g(S_weft),
// g inverted, shaded as E f with the material's colours (f carries eq. 3's
// cosine, as the reference render's pixels do) and written sRGB encoded.
// Or, with QUERIES_FROM_MESH, drawn over the woven far level's mesh
// (woven_far.vert): the query made here from the mesh's varyings and the
// result written premultiplied by the far level's share, linear (the
// composite lays it over the frame). The per-material latent comes folded into the first
// fusion layer's bias (u_fusion_bias), so a pixel pays only for the
// footprint's share.
//
// The weights are a flat array of vec4s (woven_decoder_pass.cpp lays it
// out): each layer's 4x4 blocks as mat4 columns, then its biases. In an
// RGBA32F texture WEIGHT_TEXTURE_WIDTH texels wide, or in a uniform block
// (WEIGHTS_IN_UNIFORM_BLOCK), which llvmpipe reads 1.5x slower here
// (probably lane by lane, the loops' indices not being constant). Sizes and offsets (in
// vec4s) are #defines: FUSION4, ANGULAR4, JOINED4 (= FUSION4 + 2), BLOB4,
// BLOB_BINS, FEATURE4 (the footprint's features, 0 or 3), WEIGHT_VECTORS,
// and per layer *_W (blocks) and *_B (biases).
precision highp float;
precision highp int;
precision highp sampler2D;

#ifdef WEIGHTS_IN_UNIFORM_BLOCK
layout(std140) uniform WovenWeights {
  vec4 u_vectors[WEIGHT_VECTORS];
};
vec4 weight_vector(int i) { return u_vectors[i]; }
#else
uniform sampler2D u_weights;
vec4 weight_vector(int i) {
  return texelFetch(u_weights, ivec2(i % WEIGHT_TEXTURE_WIDTH, i / WEIGHT_TEXTURE_WIDTH), 0);
}
#endif

#ifdef QUERIES_FROM_MESH
in vec3 v_position;
in vec2 v_repeat;
in vec3 v_across;
in vec3 v_normal;
in float v_yarn_px;
uniform vec3 u_eye;              // world, mm
uniform vec4 u_light;            // position (w = 1) or direction toward it (w = 0)
uniform vec2 u_fade_px;          // the far level from none (x) to all (y), x > y
#else
uniform sampler2D u_footprints;  // per pixel: u, v (repeats), size (repeats)
uniform sampler2D u_incoming;    // per pixel: wi, cloth frame
uniform sampler2D u_outgoing;    // per pixel: wo, cloth frame
#endif
uniform vec4 u_fusion_bias[FUSION4];
#if FEATURE4 > 0
// The material's footprint features' summed-area table
// (cloth::WovenFootprintFeatures): corner (i, j)'s 12 sums in texels
// 3i..3i+2 of row j, (T + 1) rows.
uniform sampler2D u_features;
#endif
uniform vec3 u_kd_warp, u_kd_weft, u_ks_warp, u_ks_weft;  // linear
uniform float u_irradiance;      // the light's, at normal incidence
// FUSION4 and ANGULAR4 again, as uniforms: the loops over a layer's outputs
// run to these, so the compiler cannot unroll them. Unrolled, the decoder
// is thousands of straight-line instructions that llvmpipe's LLVM takes
// minutes to compile; rolled, it takes about a second and runs as fast.
uniform int u_fusion4, u_angular4;

out vec4 fragment;

const float kLeaky = 0.01;
const float kSpecularK = 100.0;       // g(x) = ln(k x + 1)
const float kLargestFootprint = 5.0;  // repeats

vec4 leaky(vec4 x) { return max(x, kLeaky * x); }

// Rows 4g..4g+3 and columns 4k..4k+3 of a layer's weights.
mat4 block(int first) {
  return mat4(weight_vector(first), weight_vector(first + 1), weight_vector(first + 2),
              weight_vector(first + 3));
}

// The footprint's inputs: its one-blob, then its features.
#define FOOTPRINT4 (BLOB4 + FEATURE4)

// The layers, one function per input width (GLSL has no generic arrays);
// W and B the layer's offsets, no activation (the callers apply it).
void fusion_first(vec4 x[FOOTPRINT4], out vec4 y[FUSION4]) {
  for (int g = 0; g < u_fusion4; ++g) {
    vec4 sum = u_fusion_bias[g];
    for (int k = 0; k < FOOTPRINT4; ++k) sum += block(FUSE1_W + 4 * (g * FOOTPRINT4 + k)) * x[k];
    y[g] = sum;
  }
}
void fusion_second(vec4 x[FUSION4], out vec4 y[FUSION4]) {
  for (int g = 0; g < u_fusion4; ++g) {
    vec4 sum = weight_vector(FUSE2_B + g);
    for (int k = 0; k < FUSION4; ++k) sum += block(FUSE2_W + 4 * (g * FUSION4 + k)) * x[k];
    y[g] = sum;
  }
}
void angular_first(vec4 x[JOINED4], out vec4 y[ANGULAR4]) {
  for (int g = 0; g < u_angular4; ++g) {
    vec4 sum = weight_vector(ANG_IN_B + g);
    for (int k = 0; k < JOINED4; ++k) sum += block(ANG_IN_W + 4 * (g * JOINED4 + k)) * x[k];
    y[g] = sum;
  }
}
void angular_layer(int w, int b, vec4 x[ANGULAR4], out vec4 y[ANGULAR4]) {
  for (int g = 0; g < u_angular4; ++g) {
    vec4 sum = weight_vector(b + g);
    for (int k = 0; k < ANGULAR4; ++k) sum += block(w + 4 * (g * ANGULAR4 + k)) * x[k];
    y[g] = sum;
  }
}
vec4 angular_last(vec4 x[ANGULAR4]) {
  vec4 sum = weight_vector(ANG_OUT_B);
  for (int k = 0; k < ANGULAR4; ++k) sum += block(ANG_OUT_W + 4 * k) * x[k];
  return sum;
}

// Mueller et al.'s one-blob, as cloth::one_blob_footprint: u and v wrap.
float blob(float x, int bin, bool periodic) {
  float width = 1.0 / float(BLOB_BINS);
  float d = x - (float(bin) + 0.5) * width;
  if (periodic) d -= floor(d + 0.5);
  return exp(-0.5 * d * d / (width * width));
}

#if FEATURE4 > 0
// cloth::WovenFootprintFeatures::mean: the table read bilinearly between
// its corners (exact for texel-wise constant features), the repeat tiling
// beyond them. One channel group (c: features 4c..4c+3) at a time in a
// loop to u_feature_groups (3), kept rolled as the layers' are: unrolled,
// llvmpipe's LLVM took over 20 minutes on the mesh variant.
const float kSmallestTexels = 0.5;  // woven_footprint_smallest_texels
uniform int u_feature_groups;

// The sums of group c over [0, x) x [0, y), x and y in [0, T] texels.
vec4 corner_sum(float x, float y, int c, int t) {
  int i = clamp(int(floor(x)), 0, t - 1), j = clamp(int(floor(y)), 0, t - 1);
  float a = x - float(i), b = y - float(j);
  vec4 c00 = texelFetch(u_features, ivec2(3 * i + c, j), 0);
  vec4 c10 = texelFetch(u_features, ivec2(3 * (i + 1) + c, j), 0);
  vec4 c01 = texelFetch(u_features, ivec2(3 * i + c, j + 1), 0);
  vec4 c11 = texelFetch(u_features, ivec2(3 * (i + 1) + c, j + 1), 0);
  vec4 top = c00 + a * (c10 - c00), bottom = c01 + a * (c11 - c01);
  return top + b * (bottom - top);
}

// The features' mean over the square `footprint.z` repeats wide about
// footprint.xy. A sum from the origin to (x, y) >= 0 is, with x = kx T + fx,
// kx ky W + kx C(T, fy) + ky C(fx, T) + C(fx, fy) (W a whole repeat's).
void footprint_features(vec3 footprint, out vec4 f[3]) {
  int t = textureSize(u_features, 0).y - 1;
  float size = float(t);
  float width = max(footprint.z * size, kSmallestTexels);
  vec2 low = footprint.xy * size - 0.5 * width;
  low -= floor(low / size) * size;
  vec2 high = low + width;
  vec2 k0 = floor(low / size), k1 = floor(high / size);
  vec2 f0 = clamp(low - k0 * size, 0.0, size), f1 = clamp(high - k1 * size, 0.0, size);
  float area = width * width;
  for (int c = 0; c < u_feature_groups; ++c) {
    vec4 whole = texelFetch(u_features, ivec2(3 * t + c, t), 0);
    vec4 column0 = corner_sum(size, f0.y, c, t), column1 = corner_sum(size, f1.y, c, t);
    vec4 row0 = corner_sum(f0.x, size, c, t), row1 = corner_sum(f1.x, size, c, t);
    vec4 s11 = k1.x * k1.y * whole + k1.x * column1 + k1.y * row1 + corner_sum(f1.x, f1.y, c, t);
    vec4 s01 = k0.x * k1.y * whole + k0.x * column1 + k1.y * row0 + corner_sum(f0.x, f1.y, c, t);
    vec4 s10 = k1.x * k0.y * whole + k1.x * column0 + k0.y * row1 + corner_sum(f1.x, f0.y, c, t);
    vec4 s00 = k0.x * k0.y * whole + k0.x * column0 + k0.y * row0 + corner_sum(f0.x, f0.y, c, t);
    f[c] = (s11 - s01 - s10 + s00) / area;
  }
}
#endif

float specular_from_g(float g) { return max(0.0, (exp(g) - 1.0) / kSpecularK); }

float srgb_encode(float linear) {
  linear = clamp(linear, 0.0, 1.0);
  return linear <= 0.0031308 ? 12.92 * linear : 1.055 * pow(linear, 1.0 / 2.4) - 0.055;
}

#ifdef QUERIES_FROM_MESH
// The pixel's query (woven_neural_render.h's footprint_lookup): the centre,
// the square of the footprint's area in repeats (from the derivatives of
// the face coordinates), and the directions in the cloth's frame. Seen
// from behind, the directions are mirrored through the cloth (its back is
// shaded as its front).
void mesh_query(out vec3 footprint, out vec3 wi, out vec3 wo) {
  vec2 dx = dFdx(v_repeat), dy = dFdy(v_repeat);
  footprint = vec3(v_repeat, sqrt(abs(dx.x * dy.y - dx.y * dy.x)));
  vec3 n = normalize(v_normal);
  vec3 x = normalize(v_across - dot(v_across, n) * n);
  mat3 to_cloth = transpose(mat3(x, cross(n, x), n));
  wo = to_cloth * normalize(u_eye - v_position);
  wi = to_cloth * normalize(u_light.xyz - u_light.w * v_position);
  if (wo.z < 0.0) {
    wo.z = -wo.z;
    wi.z = -wi.z;
  }
}
#endif

void main() {
#ifdef QUERIES_FROM_MESH
  float far = 1.0 - smoothstep(u_fade_px.y, u_fade_px.x, v_yarn_px);
  if (far <= 0.0) discard;
  vec3 footprint, wi, wo;
  mesh_query(footprint, wi, wo);
#else
  // Row 0 of the inputs is the frame's top row, as OffscreenTarget::read gives it.
  ivec2 size = textureSize(u_footprints, 0);
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  pixel.y = size.y - 1 - pixel.y;
  vec3 footprint = texelFetch(u_footprints, pixel, 0).xyz;
  vec3 wi = texelFetch(u_incoming, pixel, 0).xyz;
  vec3 wo = texelFetch(u_outgoing, pixel, 0).xyz;
#endif

  float encoded[4 * BLOB4];
  vec2 position = footprint.xy - floor(footprint.xy);
  float span = clamp(footprint.z / kLargestFootprint, 0.0, 1.0);
  for (int k = 0; k < BLOB_BINS; ++k) {
    encoded[k] = blob(position.x, k, true);
    encoded[BLOB_BINS + k] = blob(position.y, k, true);
    encoded[2 * BLOB_BINS + k] = blob(span, k, false);
  }
  vec4 blobs[FOOTPRINT4];
  for (int k = 0; k < BLOB4; ++k) {
    blobs[k] = vec4(encoded[4 * k], encoded[4 * k + 1], encoded[4 * k + 2], encoded[4 * k + 3]);
  }
#if FEATURE4 > 0
  vec4 features[3];
  footprint_features(footprint, features);
  for (int c = 0; c < 3; ++c) blobs[BLOB4 + c] = features[c];
#endif

  // The spatial fusion, then the angular inputs beside it: wi xyz, wo xy.
  vec4 fused[FUSION4], spatial[FUSION4];
  fusion_first(blobs, fused);
  for (int g = 0; g < FUSION4; ++g) fused[g] = leaky(fused[g]);
  fusion_second(fused, spatial);
  vec4 joined[JOINED4];
  for (int g = 0; g < FUSION4; ++g) joined[g] = leaky(spatial[g]);
  joined[FUSION4] = vec4(wi, wo.x);
  joined[FUSION4 + 1] = vec4(wo.y, 0.0, 0.0, 0.0);

  // The angular decoder: in, a residual block, mid, out.
  vec4 x[ANGULAR4], hidden[ANGULAR4], back[ANGULAR4];
  angular_first(joined, x);
  for (int g = 0; g < ANGULAR4; ++g) x[g] = leaky(x[g]);
  angular_layer(ANG_RES1_W, ANG_RES1_B, x, hidden);
  for (int g = 0; g < ANGULAR4; ++g) hidden[g] = leaky(hidden[g]);
  angular_layer(ANG_RES2_W, ANG_RES2_B, hidden, back);
  for (int g = 0; g < ANGULAR4; ++g) x[g] = leaky(x[g] + back[g]);
  angular_layer(ANG_MID_W, ANG_MID_B, x, hidden);
  for (int g = 0; g < ANGULAR4; ++g) hidden[g] = leaky(hidden[g]);
  vec4 raw = angular_last(hidden);

  float c_warp = max(raw.x, 0.0), c_weft = max(raw.y, 0.0);
  float s_warp = specular_from_g(raw.z), s_weft = specular_from_g(raw.w);
  vec3 f = u_kd_warp * c_warp + u_kd_weft * c_weft + u_ks_warp * s_warp + u_ks_weft * s_weft;
  vec3 radiance = wi.z > 0.0 ? f * u_irradiance : vec3(0.0);
#ifdef QUERIES_FROM_MESH
  fragment = vec4(far * radiance, far);
#else
  fragment = vec4(srgb_encode(radiance.r), srgb_encode(radiance.g), srgb_encode(radiance.b), 1.0);
#endif
}
