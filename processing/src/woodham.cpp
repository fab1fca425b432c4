#include "psrig/processing/woodham.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <vector>

#include "psrig/base/parallel.h"
#include "psrig/base/vector_clones.h"
#include "psrig/formats/scan_layout.h"
#include "stream_store.h"

namespace psrig::processing {
namespace {

// Rows handed to the pool at a time: small enough to balance, large enough
// that scheduling costs nothing next to the work.
constexpr int kSolveRowsPerChunk = 8;
// The scaled normal must point out of the swatch by more than this fraction
// of its length (normal within ~89.9 degrees of the view axis).
constexpr float kMinNormalZ = 1e-3f;

// Pointers to one row of everything a kernel reads and writes.
struct RowData {
  int cols = 0;
  int stride = 0;  // cols, or more: values from one plane to the next
  int lights = 0;
  int channels = 1;
  // Planes of `cols` values each, `stride` apart: measurement plane
  // light * channels + channel, saturation plane light.
  const float* measurement = nullptr;
  const std::uint8_t* saturated = nullptr;
  const std::uint8_t* mask = nullptr;  // 0 = outside the scan's mask
  float* p = nullptr;
  float* q = nullptr;
  float* albedo = nullptr;  // interleaved channels
  float* residual = nullptr;
  std::uint8_t* flags = nullptr;
};

// The unit light directions, rows of L, as the kernels read them.
struct Coefficients {
  std::vector<std::array<float, 3>> direction;
  // l l^T of each light as {xx, xy, xz, yy, yz, zz}, summed into the
  // normal equations of the lights a pixel uses.
  std::vector<std::array<double, 6>> outer;
  // Indexed by the number m of a pixel's candidate lights: the factor that
  // makes the scale of the least-trimmed-squares residuals consistent.
  std::vector<double> lts_scale;
};

// --- Three lights: Woodham's exact inverse, the rig's case and the hot path.
// Plain loops over blocks of a row, left to the vectoriser (compiled for
// AVX2 and AVX-512 too). With g_k the grey measurements and t = L^-1 g,
// L t = g exactly, so the shading of light k is s_k = l_k.n = g_k/|t|, and
// the per-channel least-squares albedo rho_c = sum s_k m_kc / sum s_k^2
// becomes |t| w_c with w_c = sum g_k m_kc / sum g_k^2.

struct ThreeLightInverse {
  float a[3][3];  // a[row][light]: t = a g
};

// The measurement planes of one row: light k, channel c at m[k * C + c].
template <int C>
struct RowPlanes {
  const float* __restrict m[3 * C];
};

template <int C>
[[gnu::always_inline]] inline float grey(const RowPlanes<C>& planes, int k, int i) {
  if constexpr (C == 1) {
    return planes.m[k][i];
  } else {
    return (planes.m[3 * k][i] + planes.m[3 * k + 1][i] + planes.m[3 * k + 2][i]) * (1.0f / 3.0f);
  }
}

// Pixels per block. The three-light solve runs its loops over one block at
// a time (a single AVX-512 vector); between blocks it prefetches a little of
// the next row's stored input and streams out finished result lines, so that
// both memory streams overlap the arithmetic instead of stalling it at the
// ends of the row. Its rows are padded to whole blocks.
constexpr int kBlock = 16;

// Finished result lines are streamed out every this many pixels: often
// enough to spread the stores, seldom enough that the bookkeeping is cheap.
constexpr int kStreamPixels = 4 * kBlock;

int padded_to_blocks(int cols) {
  return (cols + kBlock - 1) / kBlock * kBlock;
}

// Scaled normal, gradients, and per pixel |t| and 1 / sum g^2 for the
// albedo loop; code gets the kLowSignal, kNoSolution and kShadowed bits.
// (Two loops rather than one: together they run out of vector registers.)
// Every array is 32-bit: a byte array would make the vectoriser take four
// times as many pixels per vector, and spill.
template <int C>
[[gnu::always_inline]] inline void three_light_normals(
    const RowPlanes<C>& planes, int i0, const float* __restrict inside, const ThreeLightInverse& l,
    float shadow_ratio, float low_signal, float* __restrict p, float* __restrict q,
    float* __restrict length, float* __restrict inverse_energy, std::int32_t* __restrict code) {
  for (int j = 0; j < kBlock; ++j) {
    const int i = i0 + j;
    const float x0 = grey(planes, 0, i) * inside[i], x1 = grey(planes, 1, i) * inside[i],
                x2 = grey(planes, 2, i) * inside[i];
    const float tx = l.a[0][0] * x0 + l.a[0][1] * x1 + l.a[0][2] * x2;
    const float ty = l.a[1][0] * x0 + l.a[1][1] * x1 + l.a[1][2] * x2;
    const float tz = l.a[2][0] * x0 + l.a[2][1] * x1 + l.a[2][2] * x2;
    const float t = std::sqrt(tx * tx + ty * ty + tz * tz);
    const float brightest = std::max(x0, std::max(x1, x2));
    const float darkest = std::min(x0, std::min(x1, x2));
    const bool low = !(brightest >= low_signal);
    const bool no_solution = !(tz > kMinNormalZ * t);
    const bool solved = !low && !no_solution;
    const bool shadowed = darkest < shadow_ratio * t;
    const float inverse_tz = 1.0f / tz;
    p[i] = solved ? -tx * inverse_tz : 0.0f;
    q[i] = solved ? -ty * inverse_tz : 0.0f;
    length[j] = solved ? t : 0.0f;
    inverse_energy[j] = solved ? 1.0f / (x0 * x0 + x1 * x1 + x2 * x2) : 0.0f;
    code[j] = (low ? kLowSignal : 0) | (!low && no_solution ? kNoSolution : 0) |
              (solved && shadowed ? kShadowed : 0);
  }
}

// Per channel w = sum g m / sum g^2, albedo |t| w (interleaved, as the
// output is), and the RMS misfit of m - w g over lights and channels
// (computed directly: expanding the square cancels badly in float).
template <int C>
[[gnu::always_inline]] inline void three_light_albedo(const RowPlanes<C>& planes, int i0,
                                                      const float* __restrict length,
                                                      const float* __restrict inverse_energy,
                                                      float* __restrict albedo,
                                                      float* __restrict residual) {
  constexpr float kInverseTerms = 1.0f / (3 * C);
  for (int j = 0; j < kBlock; ++j) {
    const int i = i0 + j;
    const float g0 = grey(planes, 0, i), g1 = grey(planes, 1, i), g2 = grey(planes, 2, i);
    float misfit = 0;
    for (int c = 0; c < C; ++c) {
      const float m0 = planes.m[c][i], m1 = planes.m[C + c][i], m2 = planes.m[2 * C + c][i];
      const float w = (g0 * m0 + g1 * m1 + g2 * m2) * inverse_energy[j];
      const float e0 = m0 - w * g0, e1 = m1 - w * g1, e2 = m2 - w * g2;
      albedo[C * i + c] = length[j] > 0.0f ? length[j] * w : 0.0f;  // a select: NaN input stays out
      misfit += e0 * e0 + e1 * e1 + e2 * e2;
    }
    residual[i] = length[j] > 0.0f ? std::sqrt(misfit * kInverseTerms) : 0.0f;
  }
}

[[gnu::always_inline]] inline void three_light_flags(int i0, const std::int32_t* __restrict code,
                                                     const float* __restrict inside,
                                                     const std::uint8_t* __restrict s0,
                                                     const std::uint8_t* __restrict s1,
                                                     const std::uint8_t* __restrict s2,
                                                     std::uint8_t* __restrict flags) {
  for (int j = 0; j < kBlock; ++j) {
    const int i = i0 + j;
    const auto bits =
        static_cast<std::uint8_t>(code[j] | ((s0[i] | s1[i] | s2[i]) ? kSaturated : 0));
    flags[i] = inside[i] != 0.0f ? bits : static_cast<std::uint8_t>(kOutsideMask);
  }
}

// 1 inside the mask, 0 outside, as the normals loop takes it.
PSRIG_VECTOR_CLONES
void mask_to_float(const std::uint8_t* __restrict mask, float* __restrict inside, int n) {
  for (int i = 0; i < n; ++i)
    inside[i] = mask[i] ? 1.0f : 0.0f;
}

// The next row's stored input, prefetched a block's worth at a time.
struct NextRow {
  const char* src[3] = {nullptr, nullptr, nullptr};  // per light; null when there is none
  std::ptrdiff_t pixel_bytes = 0, bytes = 0;
};

// One row of the three-light solve. Measurement and saturation planes are
// `stride` apart; they and the scratch rows are padded to whole blocks.
struct ThreeLightRow {
  const float* measurement;
  const std::uint8_t* saturated;
  const float* inside;               // 1 inside the mask, 0 outside and in the padding
  float *p, *q, *albedo, *residual;  // scratch, streamed to *_out
  std::uint8_t* flags;
  void *p_out, *q_out, *albedo_out, *residual_out, *flags_out;  // the result rows
  int cols, padded, stride, channels;
  NextRow next;
};

// Block after block: prefetch, solve into the scratch rows, now and then
// stream out what is finished.
template <int C, class Lines>
[[gnu::always_inline]] inline void three_light_row(
    const RowPlanes<C>& planes, const ThreeLightInverse& l, float shadow_ratio, float low_signal,
    const float* __restrict inside, const std::uint8_t* __restrict s0,
    const std::uint8_t* __restrict s1, const std::uint8_t* __restrict s2, float* __restrict p,
    float* __restrict q, float* __restrict albedo, float* __restrict residual,
    std::uint8_t* __restrict flags, const ThreeLightRow& row) {
  const std::size_t cols = static_cast<std::size_t>(row.cols);
  RowStream<Lines> p_out(row.p_out, p, cols * sizeof(float));
  RowStream<Lines> q_out(row.q_out, q, cols * sizeof(float));
  RowStream<Lines> albedo_out(row.albedo_out, albedo, cols * C * sizeof(float));
  RowStream<Lines> residual_out(row.residual_out, residual, cols * sizeof(float));
  RowStream<Lines> flags_out(row.flags_out, flags, cols);
  const NextRow& next = row.next;
  for (int i0 = 0; i0 < row.padded; i0 += kBlock) {
    if (next.src[0]) {
      const std::ptrdiff_t end = std::min(next.bytes, (i0 + kBlock) * next.pixel_bytes);
      for (std::ptrdiff_t at = i0 * next.pixel_bytes; at < end; at += 64)
        for (const char* src : next.src)
          __builtin_prefetch(src + at);
    }
    float length[kBlock], inverse_energy[kBlock];
    std::int32_t code[kBlock];
    three_light_normals(planes, i0, inside, l, shadow_ratio, low_signal, p, q, length,
                        inverse_energy, code);
    three_light_albedo(planes, i0, length, inverse_energy, albedo, residual);
    three_light_flags(i0, code, inside, s0, s1, s2, flags);
    const std::size_t done = static_cast<std::size_t>(i0 + kBlock);
    if (done % kStreamPixels == 0) {
      p_out.advance(done * sizeof(float));
      q_out.advance(done * sizeof(float));
      albedo_out.advance(done * C * sizeof(float));
      residual_out.advance(done * sizeof(float));
      flags_out.advance(done);
    }
  }
  p_out.finish();
  q_out.finish();
  albedo_out.finish();
  residual_out.finish();
  flags_out.finish();
}

// Planes and coefficients as local copies: no store in the loops can alias
// them, so they stay in registers.
template <int C, class Lines>
[[gnu::always_inline]] inline void three_light_row(const ThreeLightRow& r, ThreeLightInverse l,
                                                   float shadow_ratio, float low_signal) {
  RowPlanes<C> planes{};
  for (int j = 0; j < 3 * C; ++j)
    planes.m[j] = r.measurement + static_cast<std::size_t>(j) * r.stride;
  const std::uint8_t* s = r.saturated;
  three_light_row<C, Lines>(planes, l, shadow_ratio, low_signal, r.inside, s, s + r.stride,
                            s + 2 * r.stride, r.p, r.q, r.albedo, r.residual, r.flags, r);
}

template <class Lines>
[[gnu::always_inline]] inline void three_light_row(const ThreeLightRow& r,
                                                   const ThreeLightInverse& l, float shadow_ratio,
                                                   float low_signal) {
  if (r.channels == 1)
    three_light_row<1, Lines>(r, l, shadow_ratio, low_signal);
  else
    three_light_row<3, Lines>(r, l, shadow_ratio, low_signal);
}

// Compiled per ISA like PSRIG_VECTOR_CLONES, but each version streams with
// its own ISA's stores, which have to be inlined (flatten).
#ifdef PSRIG_STREAM_STORES
__attribute__((target("default"), flatten)) void solve_three_light_row(const ThreeLightRow& r,
                                                                       const ThreeLightInverse& l,
                                                                       float shadow_ratio,
                                                                       float low_signal) {
  three_light_row<StreamLinesSse2>(r, l, shadow_ratio, low_signal);
}
__attribute__((target("arch=x86-64-v3"), flatten)) void solve_three_light_row(
    const ThreeLightRow& r, const ThreeLightInverse& l, float shadow_ratio, float low_signal) {
  three_light_row<StreamLinesAvx>(r, l, shadow_ratio, low_signal);
}
__attribute__((target("arch=x86-64-v4"), flatten)) void solve_three_light_row(
    const ThreeLightRow& r, const ThreeLightInverse& l, float shadow_ratio, float low_signal) {
  three_light_row<StreamLinesAvx512>(r, l, shadow_ratio, low_signal);
}
#else
void solve_three_light_row(const ThreeLightRow& r, const ThreeLightInverse& l, float shadow_ratio,
                           float low_signal) {
  three_light_row<CopyLines>(r, l, shadow_ratio, low_signal);
}
#endif

void solve_row_three(const RowData& row, const ThreeLightInverse& inverse,
                     const SolveOptions& options, const NextRow& next) {
  thread_local std::vector<float> inside, p, q, albedo, residual;
  thread_local std::vector<std::uint8_t> flags;
  const std::size_t stride = static_cast<std::size_t>(row.stride);
  inside.resize(stride);
  std::fill(inside.begin() + row.cols, inside.end(), 0.0f);
  p.resize(stride);
  q.resize(stride);
  albedo.resize(stride * row.channels);
  residual.resize(stride);
  flags.resize(stride);
  mask_to_float(row.mask, inside.data(), row.cols);
  const ThreeLightRow r{.measurement = row.measurement,
                        .saturated = row.saturated,
                        .inside = inside.data(),
                        .p = p.data(),
                        .q = q.data(),
                        .albedo = albedo.data(),
                        .residual = residual.data(),
                        .flags = flags.data(),
                        .p_out = row.p,
                        .q_out = row.q,
                        .albedo_out = row.albedo,
                        .residual_out = row.residual,
                        .flags_out = row.flags,
                        .cols = row.cols,
                        .padded = padded_to_blocks(row.cols),
                        .stride = row.stride,
                        .channels = row.channels,
                        .next = next};
  solve_three_light_row(r, inverse, options.shadow_ratio, options.low_signal);
}

// Solves t = A^-1 b for the symmetric 3x3 A by cofactors; false when A is
// too close to singular for the lights it sums (fewer than three spread ones).
bool solve_symmetric3(const double a[6], const double b[3], double t[3]) {
  // a = {xx, xy, xz, yy, yz, zz}
  const double c00 = a[3] * a[5] - a[4] * a[4];
  const double c01 = a[2] * a[4] - a[1] * a[5];
  const double c02 = a[1] * a[4] - a[2] * a[3];
  const double c11 = a[0] * a[5] - a[2] * a[2];
  const double c12 = a[1] * a[2] - a[0] * a[4];
  const double c22 = a[0] * a[3] - a[1] * a[1];
  const double det = a[0] * c00 + a[1] * c01 + a[2] * c02;
  const double trace = a[0] + a[3] + a[5];
  if (!(det > 1e-6 * trace * trace * trace)) return false;
  const double inverse = 1 / det;
  t[0] = (c00 * b[0] + c01 * b[1] + c02 * b[2]) * inverse;
  t[1] = (c01 * b[0] + c11 * b[1] + c12 * b[2]) * inverse;
  t[2] = (c02 * b[0] + c12 * b[1] + c22 * b[2]) * inverse;
  return true;
}

// --- Robust rejection: shadows and unsaturated specular highlights.
//
// A pixel's measurements that are not Lambertian (a highlight adds to them,
// a cast shadow takes away) are outliers of the per-pixel regression
// g_k = l_k . t. Each pixel is fitted by least trimmed squares (LTS) and
// reweighted least squares, the high-breakdown regression of Rousseeuw &
// Leroy, "Robust Regression and Outlier Detection" (Wiley 1987), ch. 1 and
// 4, computed with the concentration steps of FAST-LTS (Rousseeuw & Van
// Driessen, "Computing LTS regression for large data sets", Data Mining and
// Knowledge Discovery 12, 2006):
//  1. Start: the lights left after dropping the darkest quarter and the
//     brightest sixth of the pixel's (unsaturated) values, the photometric
//     prior that shadows are darkest and highlights brightest; h is their
//     number.
//  2. A concentration step (kConcentrationSteps): refit on the h lights
//     whose residuals |g_k - l_k . t| are smallest, among the lights the
//     fit says are lit (l_k . n and g_k / rho at least shadow_ratio). Each
//     step lowers the sum of the h smallest squared residuals; a second one
//     gained 0.1-0.3 degrees on the synthetic scenes at 12 or more lights,
//     lost a little on the real ones, and cost 15 % more time at 8 lights.
//  3. Reweighting: sigma from the h residuals (sqrt(sum r^2 / (h - 3)),
//     made consistent for the trimming by lts_consistency), floored at
//     kMisfitFloor * rho + kNoiseFloor; every lit light with
//     |r_k| <= kCutoff * sigma counts, and the pixel is solved by least
//     squares from those. The floor is there because a real rig's lights
//     are never quite calibrated nor its surfaces quite Lambertian: 0.04 of
//     the albedo lies between what the synthetic glossy scenes prefer
//     (lower) and what the real grey sphere and butterfly prefer (higher);
//     processing/tests/robust_solve_test.cpp and real_data_test.cpp.
// Cost: with eight lights a few passes over the values instead of sorts,
// and three 3x3 solves (mostly from the candidates' sums less a few lights)
// where plain least squares has one; about 2.7 times plain least squares'
// CPU time for the whole solve (tests/bench/reject_bench.cpp).

struct RobustScratch {
  std::vector<std::pair<double, int>> ranked;
  std::vector<std::uint8_t> set, next, lit;
  std::vector<double> residual, key;
};

constexpr int kConcentrationSteps = 1;
constexpr int kReweights = 1;
constexpr double kCutoff = 2.5;        // Rousseeuw & Leroy's hard cutoff, in sigmas
constexpr double kMisfitFloor = 0.04;  // of the albedo
constexpr double kNoiseFloor = 0.002;  // of full scale

// Least squares over the lights in `set`. Without branches: which lights a
// pixel uses varies from pixel to pixel, and mispredicted branches would
// cost more than adding zeros (which leaves the sums bit for bit as they were).
bool sum_solve(const Coefficients& co, const std::vector<double>& grey,
               const std::vector<std::uint8_t>& set, double t[3]) {
  double a[6] = {0, 0, 0, 0, 0, 0}, b[3] = {0, 0, 0};
  const std::size_t n = grey.size();
  for (std::size_t k = 0; k < n; ++k) {
    const double w = set[k];
    const auto& o = co.outer[k];
    for (int j = 0; j < 6; ++j)
      a[j] += w * o[j];
    const auto& l = co.direction[k];
    const double g = set[k] ? grey[k] : 0.0;  // an unused light's value may be NaN
    b[0] += l[0] * g, b[1] += l[1] * g, b[2] += l[2] * g;
  }
  return solve_symmetric3(a, b, t);
}

// The normal equations of a pixel's candidate lights, from which those of a
// subset are had by taking away the few lights it leaves out: cheaper than
// summing the subset when it holds most of them (eight lights: the start
// leaves out three, the reweighting one or two).
struct NormalEquations {
  double a[6] = {0, 0, 0, 0, 0, 0}, b[3] = {0, 0, 0};
  int members = 0;
};

NormalEquations candidate_sums(const Coefficients& co, const std::vector<double>& grey,
                               const std::vector<std::uint8_t>& used) {
  NormalEquations e;
  for (std::size_t k = 0; k < grey.size(); ++k) {
    const double w = used[k];
    const auto& o = co.outer[k];
    for (int j = 0; j < 6; ++j)
      e.a[j] += w * o[j];
    const auto& l = co.direction[k];
    const double g = used[k] ? grey[k] : 0.0;
    e.b[0] += l[0] * g, e.b[1] += l[1] * g, e.b[2] += l[2] * g;
    e.members += used[k];
  }
  return e;
}

// Least squares over `set`, a subset of the candidates `all` sums.
bool subset_solve(const Coefficients& co, const std::vector<double>& grey,
                  const NormalEquations& all, const std::vector<std::uint8_t>& used,
                  const std::vector<std::uint8_t>& set, double t[3]) {
  const int members = static_cast<int>(std::count(set.begin(), set.end(), std::uint8_t{1}));
  if (2 * members < all.members) return sum_solve(co, grey, set, t);
  double a[6], b[3];
  std::copy(all.a, all.a + 6, a);
  std::copy(all.b, all.b + 3, b);
  for (std::size_t k = 0; k < grey.size(); ++k) {
    if (!used[k] || set[k]) continue;
    const auto& o = co.outer[k];
    for (int j = 0; j < 6; ++j)
      a[j] -= o[j];
    const auto& l = co.direction[k];
    b[0] -= l[0] * grey[k], b[1] -= l[1] * grey[k], b[2] -= l[2] * grey[k];
  }
  return solve_symmetric3(a, b, t);
}

// Marks out[k] = 1 for the lights k of `among` (`members` of them) whose key
// ranks in [lo, hi) among them, ties broken by index so the set is unique;
// else 0. Few to drop (eight lights: three): one pass for each, a
// branchless argmin or argmax; many: a sort.
constexpr int kDropByPasses = 8;

void mark_ranks(const double* key, const std::uint8_t* among, int n, int members, int lo, int hi,
                std::uint8_t* out, RobustScratch& s) {
  if (lo + (members - hi) <= kDropByPasses) {
    std::copy(among, among + n, out);
    const auto drop = [&](bool lowest) {
      double best_key = lowest ? std::numeric_limits<double>::infinity()
                               : -std::numeric_limits<double>::infinity();
      int best = -1;
      for (int k = 0; k < n; ++k) {
        // The first of equal lowest keys, the last of equal highest ones.
        const bool better = out[k] && (lowest ? key[k] < best_key : key[k] >= best_key);
        best_key = better ? key[k] : best_key;
        best = better ? k : best;
      }
      if (best >= 0) out[best] = 0;
    };
    for (int j = 0; j < lo; ++j)
      drop(true);
    for (int j = hi; j < members; ++j)
      drop(false);
    return;
  }
  s.ranked.clear();
  for (int k = 0; k < n; ++k) {
    out[k] = 0;
    if (among[k])
      s.ranked.emplace_back(std::isnan(key[k]) ? std::numeric_limits<double>::infinity() : key[k],
                            k);
  }
  std::sort(s.ranked.begin(), s.ranked.end());
  for (int j = std::max(lo, 0); j < std::min(hi, static_cast<int>(s.ranked.size())); ++j)
    out[s.ranked[j].second] = 1;
}

// `used` holds the candidate lights on entry (at least four) and the lights
// solved from on return; `highlight` says whether a light brighter than the
// fit by more than the cutoff was dropped.
bool robust_fit(const Coefficients& co, const std::vector<double>& grey, double shadow_ratio,
                std::vector<std::uint8_t>& used, double t[3], RobustScratch& s, bool& highlight) {
  const int n = static_cast<int>(grey.size());
  const std::size_t size = grey.size();
  const int m = static_cast<int>(std::count(used.begin(), used.end(), std::uint8_t{1}));
  const int dark = m / 4, bright = m / 6, h = m - dark - bright;
  s.set.resize(size), s.next.resize(size), s.lit.resize(size), s.residual.resize(size),
      s.key.resize(size);
  mark_ranks(grey.data(), used.data(), n, m, dark, m - bright, s.set.data(), s);
  const NormalEquations all = candidate_sums(co, grey, used);
  if (!subset_solve(co, grey, all, used, s.set, t)) {
    s.set = used;
    if (!sum_solve(co, grey, s.set, t)) return false;
  }

  // Residuals of the candidates, and which of them the fit says are lit.
  const auto residuals = [&] {
    const double rho = std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    int lit = 0;
    for (int k = 0; k < n; ++k) {
      const auto& l = co.direction[k];
      const double shade = l[0] * t[0] + l[1] * t[1] + l[2] * t[2];
      s.residual[k] = grey[k] - shade;
      s.key[k] = std::abs(s.residual[k]);
      s.lit[k] = used[k] & (shade >= shadow_ratio * rho) & (grey[k] >= shadow_ratio * rho);
      lit += s.lit[k];
    }
    return lit;
  };
  bool fresh = false;  // the residuals are those of t
  for (int step = 0; step < kConcentrationSteps; ++step) {
    const int lit = residuals();
    fresh = true;
    if (lit < 3) break;
    mark_ranks(s.key.data(), s.lit.data(), n, lit, 0, std::min(h, lit), s.next.data(), s);
    if (s.next == s.set) break;
    double next_t[3];
    if (!subset_solve(co, grey, all, used, s.next, next_t)) break;
    s.set.swap(s.next);
    std::copy(next_t, next_t + 3, t);
    fresh = false;
  }

  // Reweighting with hard 0/1 weights.
  for (int pass = 0; pass < kReweights; ++pass) {
    if (!fresh) residuals();
    fresh = false;
    const double rho = std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    double squares = 0;
    int in_set = 0;
    for (int k = 0; k < n; ++k)
      if (s.set[k]) squares += s.residual[k] * s.residual[k], ++in_set;
    const double sigma = std::max(
        co.lts_scale[static_cast<std::size_t>(m)] * std::sqrt(squares / std::max(1, in_set - 3)),
        kMisfitFloor * rho + kNoiseFloor);
    bool bright_dropped = false;
    int kept = 0;
    for (int k = 0; k < n; ++k) {
      const bool outlier = s.key[k] > kCutoff * sigma;
      s.next[k] = s.lit[k] & !outlier;
      bright_dropped |= s.lit[k] & outlier & (s.residual[k] > 0);
      kept += s.next[k];
    }
    double next_t[3];
    if (kept < 3 || !subset_solve(co, grey, all, used, s.next, next_t)) break;
    s.set.swap(s.next);
    std::copy(next_t, next_t + 3, t);
    highlight = bright_dropped;
  }
  used.swap(s.set);
  return true;
}

// Any number of lights, each pixel solving its own normal equations over
// the lights it uses (used[k] != 0): all of them, or with rejection those
// that are neither saturated nor shadowed, as long as at least three
// well-spread ones remain.
// Near-field LEDs (scan.json's position_mm): each pixel sees each light
// from its own direction and distance. Pixel (col, row) is the swatch point
// X = ((col - cx) s, (cy - row) s, 0); light k's row of L there is
// (P_k - X) |P_k|² / |P_k - X|³, the direction with the 1/r² falloff,
// scaled so that at the origin it is the unit direction and the light's
// intensity (divided out by the lineariser) is its irradiance there.
struct NearField {
  std::vector<cv::Vec3d> position;  // mm
  double pixel_size_mm = 0;
  cv::Point2d principal_point;  // px
};

// `co` with its rows for pixel (col, row) under near-field lights.
void near_field_coefficients(const NearField& near, int col, int row, Coefficients& out) {
  const cv::Vec3d x((col - near.principal_point.x) * near.pixel_size_mm,
                    (near.principal_point.y - row) * near.pixel_size_mm, 0.0);
  for (std::size_t k = 0; k < near.position.size(); ++k) {
    const cv::Vec3d& p = near.position[k];
    const cv::Vec3d d = p - x;
    const double r2 = d.dot(d);
    const cv::Vec3d v = d * (p.dot(p) / (r2 * std::sqrt(r2)));
    const std::array<float, 3> l{static_cast<float>(v[0]), static_cast<float>(v[1]),
                                 static_cast<float>(v[2])};
    out.direction[k] = l;
    out.outer[k] = {double{l[0]} * l[0], double{l[0]} * l[1], double{l[0]} * l[2],
                    double{l[1]} * l[1], double{l[1]} * l[2], double{l[2]} * l[2]};
  }
}

void solve_row_general(const RowData& row, const Coefficients& global, const SolveOptions& options,
                       const NearField* near = nullptr, int row_index = 0) {
  const int lights = row.lights, channels = row.channels;
  const std::size_t n = static_cast<std::size_t>(lights);
  thread_local std::vector<double> grey, shade;
  thread_local std::vector<std::uint8_t> saturated, used, next, dark;
  thread_local RobustScratch scratch;
  grey.resize(n), shade.resize(n), saturated.resize(n), used.resize(n), next.resize(n),
      dark.resize(n);
  const auto count = [](const std::vector<std::uint8_t>& set) {
    return static_cast<int>(std::count(set.begin(), set.end(), std::uint8_t{1}));
  };
  const auto any_both = [&](const std::vector<std::uint8_t>& a,
                            const std::vector<std::uint8_t>& b) {
    for (std::size_t k = 0; k < n; ++k)
      if (a[k] && b[k]) return true;
    return false;
  };
  thread_local Coefficients pixel;
  if (near) pixel = global;
  for (int i = 0; i < row.cols; ++i) {
    if (near) near_field_coefficients(*near, i, row_index, pixel);
    const Coefficients& co = near ? pixel : global;
    double brightest = 0;
    bool any_saturated = false;
    for (int k = 0; k < lights; ++k) {
      double sum = 0;
      for (int c = 0; c < channels; ++c)
        sum += row.measurement[(k * channels + c) * row.stride + i];
      grey[k] = sum / channels;
      brightest = std::max(brightest, grey[k]);
      saturated[k] = row.saturated[k * row.stride + i] ? 1 : 0;
      any_saturated |= saturated[k] != 0;
    }
    const bool outside = row.mask[i] == 0;
    const bool low = !(brightest >= options.low_signal);

    double t[3] = {0, 0, 0};
    // Marks in `out` the lights of `among` too dark for the albedo rho.
    const auto too_dark = [&](const std::vector<std::uint8_t>* among, double rho,
                              std::vector<std::uint8_t>& out) {
      bool any = false;
      for (int k = 0; k < lights; ++k) {
        out[k] = (!among || (*among)[k]) && grey[k] < options.shadow_ratio * rho ? 1 : 0;
        any |= out[k] != 0;
      }
      return any;
    };

    std::fill(used.begin(), used.end(), std::uint8_t{1});
    if (options.reject_outliers && lights - count(saturated) >= 3)
      for (std::size_t k = 0; k < n; ++k)
        used[k] = !saturated[k];
    bool ok = false;
    bool highlight = false;
    if (!outside && !low && options.reject_outliers && count(used) >= 4) {
      ok = robust_fit(co, grey, options.shadow_ratio, used, t, scratch, highlight);
    } else {
      ok = !outside && !low && sum_solve(co, grey, used, t);
      if (ok && options.reject_outliers) {
        // Three lights left: drop those too dark for the albedo found and
        // solve again; twice, as the first albedo is pulled down by them.
        for (int pass = 0; pass < 2; ++pass) {
          if (!too_dark(&used, std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]), dark)) break;
          for (std::size_t k = 0; k < n; ++k)
            next[k] = used[k] && !dark[k];
          double next_t[3];
          if (count(next) < 3 || !sum_solve(co, grey, next, next_t)) break;
          used.swap(next);
          std::copy(next_t, next_t + 3, t);
        }
      }
    }

    const double length = std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    const bool no_solution = !outside && !low && !(ok && t[2] > kMinNormalZ * length);
    const bool solved = !outside && !low && !no_solution;
    const bool shadowed = too_dark(nullptr, length, dark);
    // Recovered: lights were dropped and none of those left is doubtful.
    const bool recovered =
        count(used) != lights && !any_both(used, saturated) && !too_dark(&used, length, dark);
    double shade_squared = 0;
    for (int k = 0; k < lights; ++k) {
      const auto& l = co.direction[k];
      shade[k] = solved ? (l[0] * t[0] + l[1] * t[1] + l[2] * t[2]) / length : 0;
      const double used_shade = used[k] ? shade[k] : 0.0;
      shade_squared += used_shade * used_shade;
    }
    double misfit = 0;
    int terms = 0;
    for (int c = 0; c < channels; ++c) {
      double dot = 0;
      for (int k = 0; k < lights; ++k) {
        const float m = row.measurement[(k * channels + c) * row.stride + i];
        dot += used[k] ? shade[k] * m : 0.0;
      }
      const double rho = solved ? dot / shade_squared : 0;
      row.albedo[channels * i + c] = static_cast<float>(rho);
      for (int k = 0; k < lights; ++k) {
        const double e = row.measurement[(k * channels + c) * row.stride + i] - rho * shade[k];
        misfit += used[k] ? e * e : 0.0;
        terms += used[k];
      }
    }
    row.p[i] = solved ? static_cast<float>(-t[0] / t[2]) : 0.0f;
    row.q[i] = solved ? static_cast<float>(-t[1] / t[2]) : 0.0f;
    row.residual[i] = solved && terms ? static_cast<float>(std::sqrt(misfit / terms)) : 0.0f;
    row.flags[i] = static_cast<std::uint8_t>(
        (outside ? kOutsideMask : 0) | (!outside && any_saturated ? kSaturated : 0) |
        (solved && shadowed ? kShadowed : 0) | (!outside && low ? kLowSignal : 0) |
        (no_solution ? kNoSolution : 0) | (solved && recovered ? kRecovered : 0) |
        (solved && highlight ? kHighlight : 0));
  }
}

// The factor that makes the root mean square of the h = alpha n smallest of
// n normal residuals a consistent estimate of their sigma, as for the LTS
// scale (Rousseeuw & Leroy 1987, ch. 4): with q the (1 + alpha) / 2
// quantile of the standard normal, E[Z^2; |Z| <= q] = alpha - 2 q phi(q),
// and the factor is sqrt(alpha / that) (2.0 for 5 of 8 lights).
double lts_consistency(double alpha) {
  if (alpha >= 1) return 1;
  double lo = 0, hi = 10;  // q by bisection on Phi(q) = (1 + alpha) / 2
  for (int i = 0; i < 60; ++i) {
    const double mid = (lo + hi) / 2;
    (0.5 * std::erfc(-mid / std::sqrt(2.0)) < (1 + alpha) / 2 ? lo : hi) = mid;
  }
  const double q = (lo + hi) / 2;
  const double phi = std::exp(-q * q / 2) / std::sqrt(2 * std::numbers::pi);
  return std::sqrt(alpha / (alpha - 2 * q * phi));
}

Coefficients make_coefficients(const formats::Scan& scan) {
  Coefficients co;
  for (const auto& d : formats::make_light_matrix(scan.description).directions) {
    const std::array<float, 3> l{static_cast<float>(d[0]), static_cast<float>(d[1]),
                                 static_cast<float>(d[2])};
    co.direction.push_back(l);
    co.outer.push_back({double{l[0]} * l[0], double{l[0]} * l[1], double{l[0]} * l[2],
                        double{l[1]} * l[1], double{l[1]} * l[2], double{l[2]} * l[2]});
  }
  const int lights = static_cast<int>(co.direction.size());
  for (int m = 0; m <= lights; ++m)
    co.lts_scale.push_back(m >= 4 ? lts_consistency(static_cast<double>(m - m / 4 - m / 6) / m)
                                  : 1.0);
  return co;
}

ThreeLightInverse three_light_inverse(const Coefficients& co) {
  cv::Matx33d l;
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j)
      l(k, j) = co.direction[k][j];
  const cv::Matx33d inverse = l.inv(cv::DECOMP_LU);
  ThreeLightInverse result;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k)
      result.a[r][k] = static_cast<float>(inverse(r, k));
  return result;
}

}  // namespace

const char* reject_method(const SolveOptions& options, int lights) {
  return options.reject_outliers && lights >= 4 ? "lts-reweighted" : "none";
}

struct RowSolver::Setup {
  Setup(const formats::Scan& s, const SolveOptions& o, ScanLineariser l)
      : scan(s), options(o), lineariser(std::move(l)) {}
  const formats::Scan& scan;
  SolveOptions options;
  ScanLineariser lineariser;
  Coefficients co;
  // Near-field lights: per-pixel rows of L, each pixel its own least squares
  // (three lights: the same normal equations, exact up to rounding).
  std::optional<NearField> near;
  bool three = false;
  ThreeLightInverse inverse{};
};

RowSolver::RowSolver(std::unique_ptr<Setup> setup) : setup_(std::move(setup)) {}
RowSolver::RowSolver(RowSolver&&) noexcept = default;
RowSolver& RowSolver::operator=(RowSolver&&) noexcept = default;
RowSolver::~RowSolver() = default;

Result<RowSolver> RowSolver::create(const formats::Scan& scan, const SolveOptions& options) {
  auto lineariser = ScanLineariser::create(scan);
  if (!lineariser) return std::unexpected(lineariser.error());
  auto setup = std::make_unique<Setup>(scan, options, std::move(*lineariser));
  const int lights = static_cast<int>(scan.frames.size());
  setup->co = make_coefficients(scan);
  if (scan.description.near_field()) {
    if (!scan.description.pixel_size_mm)
      return std::unexpected(bad_input(
          scan.description.directory / formats::scan_files::kDescription, "lights[0].position_mm",
          "needs pixel_size_mm to place the pixels on the swatch"));
    NearField& near = setup->near.emplace();
    for (const auto& light : scan.description.lights)
      near.position.push_back(*light.position_mm);
    near.pixel_size_mm = *scan.description.pixel_size_mm;
    near.principal_point = scan.description.principal_point_px.value_or(
        cv::Point2d(0.5 * (scan.size().width - 1), 0.5 * (scan.size().height - 1)));
  }
  setup->three = lights == 3 && !options.force_least_squares && !setup->near;
  if (setup->three) setup->inverse = three_light_inverse(setup->co);
  return RowSolver(std::move(setup));
}

void RowSolver::solve(int first, int rows, SolveResult& result) const {
  const Setup& s = *setup_;
  const formats::Scan& scan = s.scan;
  const SolveOptions& options = s.options;
  const int lights = static_cast<int>(scan.frames.size());
  const int channels = scan.channels();
  const cv::Size size = scan.size();
  const cv::Size band(size.width, rows);
  result.p.create(band, CV_32F);
  result.q.create(band, CV_32F);
  result.albedo.create(band, CV_32FC(channels));
  result.residual.create(band, CV_32F);
  result.flags.create(band, CV_8U);

  parallel_chunks(rows, kSolveRowsPerChunk, [&](int begin, int end) {
    // Per-thread scratch for one row of every light's measurements.
    // Thread-local scratch is safe because nothing in this body opens a
    // nested parallel region (which could run another chunk on this thread
    // meanwhile).
    thread_local std::vector<float> measurements;
    thread_local std::vector<std::uint8_t> saturation;
    thread_local std::vector<std::uint8_t> everywhere;  // the mask row when the scan has none
    const std::size_t stride = static_cast<std::size_t>(padded_to_blocks(size.width));
    measurements.resize(stride * lights * channels);
    saturation.resize(stride * lights);
    everywhere.assign(stride, 255);
    std::vector<float*> planes(static_cast<std::size_t>(lights) * channels);
    for (std::size_t j = 0; j < planes.size(); ++j)
      planes[j] = measurements.data() + j * stride;

    RowData row;
    row.cols = size.width;
    row.stride = static_cast<int>(stride);
    row.lights = lights;
    row.channels = channels;
    row.measurement = measurements.data();
    row.saturated = saturation.data();
    for (int i = begin; i < end; ++i) {
      const int r = first + i;
      for (int k = 0; k < lights; ++k)
        s.lineariser.row(k, r, planes.data() + static_cast<std::size_t>(k) * channels,
                         saturation.data() + k * stride);
      row.mask = scan.mask.empty() ? everywhere.data() : scan.mask.ptr<std::uint8_t>(r);
      row.p = result.p.ptr<float>(i);
      row.q = result.q.ptr<float>(i);
      row.albedo = result.albedo.ptr<float>(i);
      row.residual = result.residual.ptr<float>(i);
      row.flags = result.flags.ptr<std::uint8_t>(i);
      if (s.three) {
        // The next row is usually this thread's too: the pool hands out
        // runs of consecutive chunks.
        NextRow next;
        if (r + 1 < size.height) {
          for (int k = 0; k < 3; ++k)
            next.src[k] = reinterpret_cast<const char*>(scan.frames[k].ptr(r + 1));
          next.pixel_bytes = static_cast<std::ptrdiff_t>(scan.frames[0].elemSize());
          next.bytes = next.pixel_bytes * size.width;
        }
        solve_row_three(row, s.inverse, options, next);
      } else {
        solve_row_general(row, s.co, options, s.near ? &*s.near : nullptr, r);
      }
    }
    stream_fence();
  });
}

Status solve_into(const formats::Scan& scan, const SolveOptions& options, SolveResult& result) {
  auto solver = RowSolver::create(scan, options);
  if (!solver) return std::unexpected(solver.error());
  solver->solve(0, scan.size().height, result);
  return {};
}

Result<SolveResult> solve(const formats::Scan& scan, const SolveOptions& options) {
  SolveResult result;
  if (auto ok = solve_into(scan, options, result); !ok) return std::unexpected(ok.error());
  return result;
}

cv::Mat normals_from_gradients(const cv::Mat& p, const cv::Mat& q) {
  cv::Mat normals(p.size(), CV_32FC3);
  parallel_chunks(p.rows, kSolveRowsPerChunk, [&](int begin, int end) {
    for (int r = begin; r < end; ++r) {
      const float* pr = p.ptr<float>(r);
      const float* qr = q.ptr<float>(r);
      float* out = normals.ptr<float>(r);
      for (int i = 0; i < p.cols; ++i) {
        const float inverse = 1.0f / std::sqrt(pr[i] * pr[i] + qr[i] * qr[i] + 1.0f);
        out[3 * i] = -pr[i] * inverse;
        out[3 * i + 1] = -qr[i] * inverse;
        out[3 * i + 2] = inverse;
      }
    }
  });
  return normals;
}

cv::Mat encode_valid_mask(const cv::Mat& flags) {
  cv::Mat out(flags.size(), CV_8U);
  parallel_chunks(flags.rows, kSolveRowsPerChunk, [&](int begin, int end) {
    for (int r = begin; r < end; ++r) {
      const std::uint8_t* f = flags.ptr<std::uint8_t>(r);
      std::uint8_t* o = out.ptr<std::uint8_t>(r);
      for (int i = 0; i < flags.cols; ++i)
        o[i] = is_valid(f[i]) ? 255 : 0;
    }
  });
  return out;
}

}  // namespace psrig::processing
