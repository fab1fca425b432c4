// Least-squares normal integration over a mask: the discrete problem of the
// DCT Poisson solver (integration.cpp), restricted to the pixels inside the
// mask, solved by conjugate gradients preconditioned with a multigrid
// V-cycle.
//
// The energy: over every pair of 4-neighbours both inside the mask,
//   (z[i][j+1] - z[i][j] - gx)^2 and (z[i+1][j] - z[i][j] - gy)^2,
// gx the integral of p from pixel j to j+1 along the row, gy that of -q
// down the column (the row index runs down, y up), each from the samples
// around the edge (edge_targets). With the trapezoid for the integrals and
// every pixel inside, this would be the Poisson solver's energy. Its normal
// equations A z = b have A the graph Laplacian of the mask's 4-neighbour
// graph, (A z)_i = sum_j w_ij (z_i - z_j) with edge weights w in {0, 1}, and
// b_i the sum over i's edges of the target difference toward i. A is
// singular (one free constant per connected piece of the mask), b is in its
// range, and CG stays there; the constants are fixed at the end (zero mean
// per piece). Vectors are float, sums double: the recurrence's residual
// reaches a floor near 1e-6 of |b| (1e-5 at 12 MP), which the default
// tolerance, 1e-5, sits at.
//
// Preconditioner: one symmetric V-cycle (two red-black Gauss-Seidel sweeps,
// red then black before, black then red after: at 12 MP, 6 CG iterations
// instead of 9 with one, for about the same time) over a hierarchy made by 2x2
// aggregation. A coarse cell's edge to its right-hand neighbour weighs half
// the sum of the fine edges between the two blocks, which is the fine
// Laplacian rediscretised on the coarse grid where the mask is full (the
// Galerkin product of piecewise-constant aggregation would be twice that
// and under-correct smooth errors by half), and follows the mask's shape
// where it is not: blocks with no edge between them stay unconnected.
// Restriction sums a block's residuals, prolongation copies the coarse
// correction into the block's pixels inside the mask. Everything is
// symmetric, so the V-cycle is a valid CG preconditioner. The four
// half-sweeps before (and the prolongation and four after) go over memory
// once, as a wavefront down the rows (fused_pass), with the values of four
// passes: the solve is bound by memory bandwidth.
// References: W. L. Briggs, V. E. Henson, S. F. McCormick, "A Multigrid
// Tutorial", SIAM 2000; Y. Notay, "An aggregation-based algebraic multigrid
// method", ETNA 37, 2010 (aggregation and the scaled coarse correction);
// Y. Queau, J.-D. Durou, J.-F. Aujol, "Normal integration: a survey", JMIV
// 60, 2018 (least squares over a non-rectangular domain).

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "gradient_inputs.h"
#include "psrig/base/memory_use.h"
#include "psrig/base/parallel.h"
#include "psrig/base/vector_clones.h"
#include "psrig/processing/integration.h"

namespace psrig::processing {
namespace {

constexpr int kRowsPerChunk = 16;
// A fused pass's chunks (fused_pass): the rows around their edges are done
// twice over, so longer ones.
constexpr int kFusedRows = 64;
// Below this relative residual, a rise means float rounding has taken over.
constexpr double kFloorZone = 1e-3;

inline bool is_finite(float value) {
  return (std::bit_cast<std::uint32_t>(value) & 0x7F800000U) != 0x7F800000U;
}

// One level of the hierarchy: a w x h grid, row-major. wx[k] is the weight of
// the edge from k to its right-hand neighbour (0 in the last column), wy[k]
// of the edge to the pixel below (0 in the last row); diag[k] the sum of k's
// edge weights, 0 for a pixel outside the mask (or one with no neighbour
// inside), which the solver leaves alone. A Gauss-Seidel step multiplies by
// 1 / diag, worked out where it is needed rather than stored: at 12 MP the
// hierarchy is 25 % smaller for it.
//
// The finest level's weights are all 0 or 1: it keeps them packed in one
// byte per pixel instead (bit 0: the edge to the right, bit 1: the edge
// down, bits 2-4: the degree), a sixteenth of the bytes of four floats in
// the loops that dominate the solve.
struct Level {
  int w = 0;
  int h = 0;
  std::vector<float> wx, wy, diag;
  std::vector<std::uint8_t> edges;  // packed instead of the four above
  std::vector<float> x, b;          // the coarse levels' own vectors
  std::vector<float> r;             // the coarsest's right-hand side, made consistent

  [[nodiscard]] std::size_t size() const { return static_cast<std::size_t>(w) * h; }
  [[nodiscard]] bool packed() const { return !edges.empty(); }
  [[nodiscard]] float right(std::size_t k) const {
    return packed() ? static_cast<float>(edges[k] & 1U) : wx[k];
  }
  [[nodiscard]] float down(std::size_t k) const {
    return packed() ? static_cast<float>((edges[k] >> 1U) & 1U) : wy[k];
  }
  [[nodiscard]] float degree(std::size_t k) const {
    return packed() ? static_cast<float>((edges[k] >> 2U) & 7U) : diag[k];
  }
  [[nodiscard]] float inv_degree(std::size_t k) const {
    const float d = degree(k);
    return d > 0 ? 1.0F / d : 0.0F;
  }
};

void finish_level(Level& level) {
  const std::size_t n = level.size();
  level.diag.assign(n, 0.0F);
  parallel_chunks(level.h, kRowsPerChunk, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      for (int j = 0; j < level.w; ++j) {
        const std::size_t k = static_cast<std::size_t>(i) * level.w + j;
        float d = level.wx[k] + level.wy[k];
        if (j > 0) d += level.wx[k - 1];
        if (i > 0) d += level.wy[k - level.w];
        level.diag[k] = d;
      }
    }
  });
}

Level coarsen(const Level& fine) {
  Level c;
  c.w = (fine.w + 1) / 2;
  c.h = (fine.h + 1) / 2;
  c.wx.assign(c.size(), 0.0F);
  c.wy.assign(c.size(), 0.0F);
  const int fw = fine.w;
  parallel_chunks(c.h, kRowsPerChunk, [&](int begin, int end) {
    for (int ci = begin; ci < end; ++ci) {
      for (int cj = 0; cj < c.w; ++cj) {
        const std::size_t k = static_cast<std::size_t>(ci) * c.w + cj;
        float sx = 0.0F;
        float sy = 0.0F;
        for (int di = 0; di < 2; ++di) {
          const int i = 2 * ci + di;
          if (i >= fine.h) break;
          const int j = 2 * cj + 1;  // the fine column whose right edge leaves the block
          if (j + 1 < fw) sx += fine.right(static_cast<std::size_t>(i) * fw + j);
        }
        for (int dj = 0; dj < 2; ++dj) {
          const int j = 2 * cj + dj;
          if (j >= fw) break;
          const int i = 2 * ci + 1;  // the fine row whose lower edge leaves the block
          if (i + 1 < fine.h) sy += fine.down(static_cast<std::size_t>(i) * fw + j);
        }
        c.wx[k] = 0.5F * sx;  // 0.45 or 0.55 take 12 iterations at 12 MP, not 9
        c.wy[k] = 0.5F * sy;
      }
    }
  });
  finish_level(c);
  c.x.assign(c.size(), 0.0F);
  c.b.assign(c.size(), 0.0F);
  return c;
}

// sum_j w_ij x_j over the four neighbours of (i, j) = k.
inline float neighbour_sum(const Level& l, const float* x, int i, int j, std::size_t k) {
  float s = 0.0F;
  if (j + 1 < l.w) s += l.right(k) * x[k + 1];
  if (j > 0) s += l.right(k - 1) * x[k - 1];
  if (i + 1 < l.h) s += l.down(k) * x[k + l.w];
  if (i > 0) s += l.down(k - l.w) * x[k - l.w];
  return s;
}

// The hot loops, over the inner columns [1, w - 1) of an inner row (one
// with a row above and below), where every neighbour exists: branch-free,
// so they vectorise. `k` is the index of column 0 of the row.
// out[j] = (b + sum of the neighbours) / diag: the Gauss-Seidel value.
PSRIG_VECTOR_CLONES
void gs_values_row(const float* __restrict wx, const float* __restrict wy,
                   const float* __restrict diag, const float* __restrict x,
                   const float* __restrict b, float* __restrict out, std::size_t k, int w) {
  for (int j = 1; j + 1 < w; ++j) {
    const std::size_t c = k + static_cast<std::size_t>(j);
    out[j] =
        (b[c] + wx[c] * x[c + 1] + wx[c - 1] * x[c - 1] + wy[c] * x[c + w] + wy[c - w] * x[c - w]) *
        (diag[c] > 0 ? 1.0F / diag[c] : 0.0F);
  }
}

// r = b - A x over the inner columns, into r[j].
PSRIG_VECTOR_CLONES
void residual_row(const float* __restrict wx, const float* __restrict wy,
                  const float* __restrict diag, const float* __restrict x,
                  const float* __restrict b, float* __restrict r, std::size_t k, int w) {
  for (int j = 1; j + 1 < w; ++j) {
    const std::size_t c = k + static_cast<std::size_t>(j);
    r[j] = b[c] - diag[c] * x[c] +
           (wx[c] * x[c + 1] + wx[c - 1] * x[c - 1] + wy[c] * x[c + w] + wy[c - w] * x[c - w]);
  }
}

// The same three over packed weights.
PSRIG_VECTOR_CLONES
void gs_values_row_packed(const std::uint8_t* __restrict edges, const float* __restrict x,
                          const float* __restrict b, float* __restrict out, std::size_t k, int w) {
  for (int j = 1; j + 1 < w; ++j) {
    const std::size_t c = k + static_cast<std::size_t>(j);
    const unsigned e = edges[c];
    const auto wr = static_cast<float>(e & 1U);
    const auto wd = static_cast<float>((e >> 1U) & 1U);
    const auto wl = static_cast<float>(edges[c - 1] & 1U);
    const auto wu = static_cast<float>((edges[c - w] >> 1U) & 1U);
    const auto d = static_cast<float>(e >> 2U);
    const float s = b[c] + wr * x[c + 1] + wl * x[c - 1] + wd * x[c + w] + wu * x[c - w];
    out[j] = d > 0.0F ? s / d : 0.0F;
  }
}

PSRIG_VECTOR_CLONES
void residual_row_packed(const std::uint8_t* __restrict edges, const float* __restrict x,
                         const float* __restrict b, float* __restrict r, std::size_t k, int w) {
  for (int j = 1; j + 1 < w; ++j) {
    const std::size_t c = k + static_cast<std::size_t>(j);
    const unsigned e = edges[c];
    const auto wr = static_cast<float>(e & 1U);
    const auto wd = static_cast<float>((e >> 1U) & 1U);
    const auto wl = static_cast<float>(edges[c - 1] & 1U);
    const auto wu = static_cast<float>((edges[c - w] >> 1U) & 1U);
    const auto d = static_cast<float>(e >> 2U);
    r[j] = b[c] - d * x[c] + (wr * x[c + 1] + wl * x[c - 1] + wd * x[c + w] + wu * x[c - w]);
  }
}

PSRIG_VECTOR_CLONES
void apply_row_packed(const std::uint8_t* __restrict edges, const float* __restrict x,
                      float* __restrict out, std::size_t k, int w) {
  for (int j = 1; j + 1 < w; ++j) {
    const std::size_t c = k + static_cast<std::size_t>(j);
    const unsigned e = edges[c];
    const auto wr = static_cast<float>(e & 1U);
    const auto wd = static_cast<float>((e >> 1U) & 1U);
    const auto wl = static_cast<float>(edges[c - 1] & 1U);
    const auto wu = static_cast<float>((edges[c - w] >> 1U) & 1U);
    const auto d = static_cast<float>(e >> 2U);
    out[j] = d * x[c] - (wr * x[c + 1] + wl * x[c - 1] + wd * x[c + w] + wu * x[c - w]);
  }
}

// sum a[k] b[k] over [begin, end) in double, in eight lanes (a fixed order,
// which lets the loop vectorise).
PSRIG_VECTOR_CLONES
double dot_range(const float* __restrict a, const float* __restrict b, std::size_t begin,
                 std::size_t end) {
  constexpr std::size_t kLanes = 8;
  double lanes[kLanes] = {};
  std::size_t k = begin;
  for (; k + kLanes <= end; k += kLanes)
    for (std::size_t lane = 0; lane < kLanes; ++lane)
      lanes[lane] += static_cast<double>(a[k + lane]) * static_cast<double>(b[k + lane]);
  double s = 0.0;
  for (double lane : lanes)
    s += lane;
  for (; k < end; ++k)
    s += static_cast<double>(a[k]) * b[k];
  return s;
}

// Row i's pixels of one colour ((i + j) % 2) get their Gauss-Seidel value.
// A pixel's neighbours all have the other colour, so the whole row's values
// can be computed first (vectorised) and those of the colour stored.
void smooth_row(const Level& l, float* x, const float* b, int i, int colour, float* values) {
  const std::size_t row = static_cast<std::size_t>(i) * l.w;
  const int first = (i + colour) & 1;
  if (i > 0 && i + 1 < l.h && l.w > 2) {
    if (l.packed())
      gs_values_row_packed(l.edges.data(), x, b, values, row, l.w);
    else
      gs_values_row(l.wx.data(), l.wy.data(), l.diag.data(), x, b, values, row, l.w);
    for (int j = first == 0 ? 2 : 1; j + 1 < l.w; j += 2)
      x[row + j] = values[static_cast<std::size_t>(j)];
    if (first == 0) x[row] = (b[row] + neighbour_sum(l, x, i, 0, row)) * l.inv_degree(row);
    const int last = l.w - 1;
    if (((i + last + colour) & 1) == 0)
      x[row + last] =
          (b[row + last] + neighbour_sum(l, x, i, last, row + last)) * l.inv_degree(row + last);
    return;
  }
  for (int j = first; j < l.w; j += 2) {
    const std::size_t k = row + j;
    x[k] = (b[k] + neighbour_sum(l, x, i, j, k)) * l.inv_degree(k);
  }
}

// One Gauss-Seidel half-sweep over the pixels of one colour.
// With `dot`, the last half-sweep of a V-cycle: also returns b.x, summed
// per chunk of rows as `reduce_rows` sums (each chunk's rows are final once
// the chunk is done).
double smooth_colour(const Level& l, float* x, const float* b, int colour, bool dot = false) {
  std::vector<double> sums(dot ? static_cast<std::size_t>(chunk_count(l.h, kRowsPerChunk)) : 0U,
                           0.0);
  parallel_chunks(l.h, kRowsPerChunk, [&](int begin, int end) {
    std::vector<float> values(static_cast<std::size_t>(l.w));
    for (int i = begin; i < end; ++i)
      smooth_row(l, x, b, i, colour, values.data());
    if (dot)
      sums[static_cast<std::size_t>(begin / kRowsPerChunk)] = dot_range(
          b, x, static_cast<std::size_t>(begin) * l.w, static_cast<std::size_t>(end) * l.w);
  });
  double total = 0.0;
  for (double sum : sums)
    total += sum;
  return total;
}

PSRIG_VECTOR_CLONES
void start_row_packed(const std::uint8_t* __restrict edges, const float* __restrict b,
                      float* __restrict x, int parity, int w) {
  for (int j = 0; j < w; ++j) {
    const auto d = static_cast<float>(edges[j] >> 2U);
    const float value = b[j] / (d > 0.0F ? d : 1.0F);
    x[j] = ((j & 1) == parity) && d > 0.0F ? value : 0.0F;
  }
}

// The first half-sweep from x = 0 on row i: colour 0 gets b / diag (its
// neighbours are all 0), colour 1 stays 0.
void start_row(const Level& l, float* x, const float* b, int i) {
  const std::size_t row = static_cast<std::size_t>(i) * l.w;
  const int parity = i & 1;
  if (l.packed()) {
    start_row_packed(l.edges.data() + row, b + row, x + row, parity, l.w);
  } else {
    for (int j = 0; j < l.w; ++j)
      x[row + j] = ((j & 1) == parity) ? b[row + j] * l.inv_degree(row + j) : 0.0F;
  }
}

// Row i of r = b - A x, into out (w values).
void residual_of_row(const Level& l, const float* x, const float* b, int i, float* out) {
  const std::size_t row = static_cast<std::size_t>(i) * l.w;
  const bool inner_row = i > 0 && i + 1 < l.h && l.w > 2;
  if (inner_row) {
    if (l.packed())
      residual_row_packed(l.edges.data(), x, b, out, row, l.w);
    else
      residual_row(l.wx.data(), l.wy.data(), l.diag.data(), x, b, out, row, l.w);
  }
  const int step = inner_row ? l.w - 1 : 1;  // inner rows: the two ends only
  for (int j = 0; j < l.w; j += step) {
    const std::size_t k = row + j;
    out[j] = b[k] - (l.degree(k) * x[k] - neighbour_sum(l, x, i, j, k));
  }
}

// out = A x over the inner columns.
PSRIG_VECTOR_CLONES
void apply_row(const float* __restrict wx, const float* __restrict wy, const float* __restrict diag,
               const float* __restrict x, float* __restrict out, std::size_t k, int w) {
  for (int j = 1; j + 1 < w; ++j) {
    const std::size_t c = k + static_cast<std::size_t>(j);
    out[j] = diag[c] * x[c] -
             (wx[c] * x[c + 1] + wx[c - 1] * x[c - 1] + wy[c] * x[c + w] + wy[c - w] * x[c - w]);
  }
}

// d = z + beta d and ad = A z + beta ad (= A d) over one row; returns d.ad.
PSRIG_VECTOR_CLONES
double direction_row(const float* __restrict az, const float* __restrict z, float beta,
                     float* __restrict d, float* __restrict ad, int w) {
  double lanes[8] = {};
  int j = 0;
  for (; j + 8 <= w; j += 8)
    for (int lane = 0; lane < 8; ++lane) {
      const int c = j + lane;
      d[c] = z[c] + beta * d[c];
      ad[c] = az[c] + beta * ad[c];
      lanes[lane] += static_cast<double>(d[c]) * static_cast<double>(ad[c]);
    }
  double s = 0.0;
  for (double lane : lanes)
    s += lane;
  for (; j < w; ++j) {
    d[j] = z[j] + beta * d[j];
    ad[j] = az[j] + beta * ad[j];
    s += static_cast<double>(d[j]) * ad[j];
  }
  return s;
}

double reduce_rows(int height, const std::function<double(int, int)>& body);

// The conjugate direction's update, fused: d = z + beta d, ad = A z +
// beta ad; returns d.ad.
double update_direction(const Level& l, const float* z, float beta, float* d, float* ad) {
  return reduce_rows(l.h, [&](int begin, int end) {
    std::vector<float> az(static_cast<std::size_t>(l.w));
    double s = 0.0;
    for (int i = begin; i < end; ++i) {
      const std::size_t row = static_cast<std::size_t>(i) * l.w;
      const bool inner_row = i > 0 && i + 1 < l.h && l.w > 2;
      if (inner_row) {
        if (l.packed())
          apply_row_packed(l.edges.data(), z, az.data(), row, l.w);
        else
          apply_row(l.wx.data(), l.wy.data(), l.diag.data(), z, az.data(), row, l.w);
      }
      const int step = inner_row ? l.w - 1 : 1;  // inner rows: the two ends only
      for (int j = 0; j < l.w; j += step) {
        const std::size_t k = row + j;
        az[static_cast<std::size_t>(j)] = l.degree(k) * z[k] - neighbour_sum(l, z, i, j, k);
      }
      s += direction_row(az.data(), z + row, beta, d + row, ad + row, l.w);
    }
    return s;
  });
}

// The coarse right-hand side: each 2x2 block's sum of the fine residual
// b - A x, computed a pair of rows at a time and never stored whole.
void restrict_residual(const Level& fine, const float* x, const float* b, Level& coarse) {
  parallel_chunks(coarse.h, kRowsPerChunk, [&](int begin, int end) {
    std::vector<float> r0(static_cast<std::size_t>(fine.w));
    std::vector<float> r1(static_cast<std::size_t>(fine.w));
    for (int ci = begin; ci < end; ++ci) {
      residual_of_row(fine, x, b, 2 * ci, r0.data());
      if (2 * ci + 1 < fine.h)
        residual_of_row(fine, x, b, 2 * ci + 1, r1.data());
      else
        std::fill(r1.begin(), r1.end(), 0.0F);
      float* out = coarse.b.data() + static_cast<std::size_t>(ci) * coarse.w;
      int cj = 0;
      for (; 2 * cj + 1 < fine.w; ++cj)
        out[cj] = (r0[2 * cj] + r0[2 * cj + 1]) + (r1[2 * cj] + r1[2 * cj + 1]);
      if (cj < coarse.w) out[cj] = r0[2 * cj] + r1[2 * cj];  // an odd width's last column
    }
  });
}

PSRIG_VECTOR_CLONES
void prolong_row_packed(const std::uint8_t* __restrict edges, const float* __restrict coarse,
                        float* __restrict x, int w) {
  const int pairs = w / 2;
  for (int jc = 0; jc < pairs; ++jc) {
    const float c = coarse[jc];
    x[2 * jc] += (edges[2 * jc] >> 2U) != 0 ? c : 0.0F;
    x[2 * jc + 1] += (edges[2 * jc + 1] >> 2U) != 0 ? c : 0.0F;
  }
  if (w % 2 != 0) x[w - 1] += (edges[w - 1] >> 2U) != 0 ? coarse[pairs] : 0.0F;
}

// Row i of the coarse correction added to the fine pixels inside the mask.
void prolong_row(const Level& coarse, const Level& fine, float* x, int i) {
  const float* c = coarse.x.data() + static_cast<std::size_t>(i / 2) * coarse.w;
  float* row = x + static_cast<std::size_t>(i) * fine.w;
  const std::size_t start = static_cast<std::size_t>(i) * fine.w;
  if (fine.packed()) {
    prolong_row_packed(fine.edges.data() + start, c, row, fine.w);
  } else {
    const float* d = fine.diag.data() + start;
    for (int j = 0; j < fine.w; ++j)
      row[j] += d[j] > 0 ? c[j / 2] : 0.0F;
  }
}

// What a stage of a fused pass does to a row: the first half-sweep from
// x = 0 (start_row), the coarse correction added (prolong_row), or a
// Gauss-Seidel half-sweep of one colour (smooth_row).
struct Stage {
  enum class Kind { from_zero, prolong, sweep } kind;
  int colour = 0;
};

// The stages one after another, each over the whole grid, in one pass over
// memory with the same result. A half-sweep's values depend only on the
// other colour's from the stage before, on its own row and the rows beside
// (start_row and prolong_row on their own row alone), so within a chunk of
// rows stage s can take row i - s as soon as stage 0 has taken row i: a
// wavefront. Near the edge between two chunks a stage waits for the chunk
// beside, so those few rows (s each side for stage s) are done after, stage
// by stage, around each edge. `coarse`: the level prolong_row takes from.
void fused_pass(const Level& l, float* x, const float* b, const Level* coarse,
                const std::vector<Stage>& stages) {
  const int n = static_cast<int>(stages.size());
  const auto apply = [&](const Stage& stage, int i, float* values) {
    switch (stage.kind) {
      case Stage::Kind::from_zero:
        start_row(l, x, b, i);
        break;
      case Stage::Kind::prolong:
        prolong_row(*coarse, l, x, i);
        break;
      case Stage::Kind::sweep:
        smooth_row(l, x, b, i, stage.colour, values);
        break;
    }
  };
  parallel_chunks(l.h, kFusedRows, [&](int begin, int end) {
    std::vector<float> values(static_cast<std::size_t>(l.w));
    for (int step = begin; step < end + n - 1; ++step)
      for (int s = 0; s < n; ++s) {
        const int i = step - s;
        const int lo = begin == 0 ? 0 : begin + s;
        const int hi = end == l.h ? l.h : end - s;
        if (i >= lo && i < hi) apply(stages[static_cast<std::size_t>(s)], i, values.data());
      }
  });
  const int edges = chunk_count(l.h, kFusedRows) - 1;
  parallel_chunks(edges, 1, [&](int first, int last) {
    std::vector<float> values(static_cast<std::size_t>(l.w));
    for (int edge = first; edge < last; ++edge) {
      const int e = (edge + 1) * kFusedRows;
      for (int s = 1; s < n; ++s)
        for (int i = std::max(0, e - s); i < std::min(l.h, e + s); ++i)
          apply(stages[static_cast<std::size_t>(s)], i, values.data());
    }
  });
}

// b.x summed per chunk of rows (its inner rows, then its first and last),
// chunk after chunk: the order the V-cycle has always summed it in, so CG
// takes the very same steps.
double chunk_dot(const Level& l, const float* b, const float* x) {
  const auto chunks = static_cast<std::size_t>(chunk_count(l.h, kRowsPerChunk));
  std::vector<double> inner(chunks, 0.0);
  std::vector<double> edge(chunks, 0.0);
  parallel_chunks(l.h, kRowsPerChunk, [&](int begin, int end) {
    const auto chunk = static_cast<std::size_t>(begin / kRowsPerChunk);
    const auto row = [&](int i) {
      return dot_range(b, x, static_cast<std::size_t>(i) * l.w,
                       static_cast<std::size_t>(i + 1) * l.w);
    };
    if (end - begin > 2)
      inner[chunk] = dot_range(b, x, static_cast<std::size_t>(begin + 1) * l.w,
                               static_cast<std::size_t>(end - 1) * l.w);
    edge[chunk] = row(begin) + (end - 1 > begin ? row(end - 1) : 0.0);
  });
  double total = 0.0;
  for (std::size_t chunk = 0; chunk < chunks; ++chunk)
    total += inner[chunk] + edge[chunk];
  return total;
}

class Multigrid {
 public:
  explicit Multigrid(Level finest) {
    levels_.push_back(std::move(finest));
    while (levels_.back().w > 4 && levels_.back().h > 4 && levels_.size() < 24)
      levels_.push_back(coarsen(levels_.back()));
  }

  [[nodiscard]] const Level& finest() const { return levels_.front(); }

  // z = M r: one V-cycle from zero. z and r are finest-level vectors.
  // Returns r.z.
  double apply(const float* r, float* z) { return cycle(0, r, z); }

 private:
  // Returns b.x on the finest level.
  double cycle(std::size_t index, const float* b, float* x) {
    Level& l = levels_[index];
    if (index + 1 == levels_.size()) {
      std::fill(x, x + l.size(), 0.0F);
      // The coarsest grid has a few dozen cells: symmetric sweeps until it
      // is solved well enough for a preconditioner. Its right-hand side is
      // first made consistent (zero sum over each connected piece): rounding
      // leaves a little of the null space in it, which the sweeps would
      // otherwise amplify without bound.
      std::vector<float>& rhs = l.r;
      rhs.assign(b, b + l.size());
      project_pieces(l, rhs.data());
      for (int sweep = 0; sweep < 64; ++sweep) {
        smooth_colour(l, x, rhs.data(), 0);
        smooth_colour(l, x, rhs.data(), 1);
        smooth_colour(l, x, rhs.data(), 1);
        smooth_colour(l, x, rhs.data(), 0);
      }
      project_pieces(l, x);
      return index == 0 ? dot_range(b, x, 0, l.size()) : 0.0;
    }
    using Kind = Stage::Kind;
    Level& c = levels_[index + 1];
    // Red then black twice before (the first from x = 0), black then red
    // twice after, each four in one pass.
    fused_pass(l, x, b, nullptr,
               {{Kind::from_zero}, {Kind::sweep, 1}, {Kind::sweep, 0}, {Kind::sweep, 1}});
    restrict_residual(l, x, b, c);
    cycle(index + 1, c.b.data(), c.x.data());
    fused_pass(
        l, x, b, &c,
        {{Kind::prolong}, {Kind::sweep, 1}, {Kind::sweep, 0}, {Kind::sweep, 1}, {Kind::sweep, 0}});
    return index == 0 ? chunk_dot(l, b, x) : 0.0;
  }

  // Removes from v its mean over each connected piece of the coarsest grid.
  void project_pieces(const Level& l, float* v) {
    if (pieces_.empty()) label_pieces(l);
    std::vector<double> sum(piece_count_, 0.0);
    std::vector<double> count(piece_count_, 0.0);
    for (std::size_t k = 0; k < l.size(); ++k)
      if (pieces_[k] >= 0) {
        sum[static_cast<std::size_t>(pieces_[k])] += v[k];
        count[static_cast<std::size_t>(pieces_[k])] += 1.0;
      }
    for (std::size_t k = 0; k < l.size(); ++k)
      if (pieces_[k] >= 0)
        v[k] -= static_cast<float>(sum[static_cast<std::size_t>(pieces_[k])] /
                                   count[static_cast<std::size_t>(pieces_[k])]);
  }

  // Labels the coarsest grid's connected pieces (edges of positive weight);
  // cells with no edge get -1.
  void label_pieces(const Level& l) {
    pieces_.assign(l.size(), -1);
    piece_count_ = 0;
    std::vector<std::size_t> stack;
    for (std::size_t start = 0; start < l.size(); ++start) {
      if (pieces_[start] >= 0 || !(l.degree(start) > 0)) continue;
      const int label = static_cast<int>(piece_count_++);
      pieces_[start] = label;
      stack.assign(1, start);
      while (!stack.empty()) {
        const std::size_t k = stack.back();
        stack.pop_back();
        const auto w = static_cast<std::size_t>(l.w);
        const auto visit = [&](std::size_t next, float weight) {
          if (weight > 0 && pieces_[next] < 0) {
            pieces_[next] = label;
            stack.push_back(next);
          }
        };
        if ((k % w) + 1 < w) visit(k + 1, l.right(k));
        if (k % w > 0) visit(k - 1, l.right(k - 1));
        if (k + w < l.size()) visit(k + w, l.down(k));
        if (k >= w) visit(k - w, l.down(k - w));
      }
    }
  }

  std::vector<Level> levels_;
  std::vector<int> pieces_;
  std::size_t piece_count_ = 0;
};

// Sum over chunks of rows, each in double, combined in chunk order.
double reduce_rows(int height, const std::function<double(int, int)>& body) {
  std::vector<double> sums(static_cast<std::size_t>(chunk_count(height, kRowsPerChunk)), 0.0);
  parallel_chunks(height, kRowsPerChunk, [&](int begin, int end) {
    sums[static_cast<std::size_t>(begin / kRowsPerChunk)] = body(begin, end);
  });
  double total = 0.0;
  for (double s : sums)
    total += s;
  return total;
}

template <typename Body>
double reduce(int height, const Body& body) {
  return reduce_rows(height, body);
}

double dot(const std::vector<float>& a, const std::vector<float>& b, int w, int h) {
  return reduce(h, [&](int begin, int end) {
    return dot_range(a.data(), b.data(), static_cast<std::size_t>(begin) * w,
                     static_cast<std::size_t>(end) * w);
  });
}

// x += alpha d, r -= alpha ad over [begin, end); returns the new r.r there.
PSRIG_VECTOR_CLONES
double step_range(float* __restrict x, float* __restrict r, const float* __restrict d,
                  const float* __restrict ad, float alpha, std::size_t begin, std::size_t end) {
  for (std::size_t k = begin; k < end; ++k) {
    x[k] += alpha * d[k];
    r[k] -= alpha * ad[k];
  }
  return dot_range(r, r, begin, end);
}

// One row of gradients as edge_targets takes them: clamped, 0 outside the
// domain, and the domain as 1 / 0.
PSRIG_VECTOR_CLONES
void load_row(const float* __restrict g, const std::uint8_t* __restrict inside, float limit,
              float* __restrict values, float* __restrict inside_row, int w) {
  for (int j = 0; j < w; ++j) {
    const float m = inside[j] != 0 ? 1.0F : 0.0F;
    // Outside, g may be NaN: select rather than multiply.
    values[j] = inside[j] != 0 ? std::clamp(g[j], -limit, limit) : 0.0F;
    inside_row[j] = m;
  }
}

// The target of z[k+1] - z[k] on one edge: the integral of the derivative
// from sample k to k+1, from the cubic through the four samples around the
// edge, (-g[k-1] + 13 g[k] + 13 g[k+1] - g[k+2]) / 24 (fourth order), or
// the quadratic through the three there are where the mask cuts one off
// (third order), or the trapezoid (g[k] + g[k+1]) / 2 between two samples
// alone. The trapezoid everywhere (the Poisson solver's rule) errs by
// g''/12 per edge, which on a steep, curved silhouette adds up to tenths of
// a unit.
//
// edge_targets computes it for `count` edges at once, branch-free: samples g0 -> g1 are
// the edge's ends, gb before and ga after; m* say which are inside. Also
// the edge's weight, 1 when both ends are inside, else 0 (and target 0).
PSRIG_VECTOR_CLONES
void edge_targets(const float* __restrict gb, const float* __restrict g0,
                  const float* __restrict g1, const float* __restrict ga,
                  const float* __restrict mb, const float* __restrict m0,
                  const float* __restrict m1, const float* __restrict ma, float* __restrict target,
                  float* __restrict weight, int count) {
  for (int j = 0; j < count; ++j) {
    const float both = mb[j] * ma[j];
    const float before_only = mb[j] - both;
    const float after_only = ma[j] - both;
    const float neither = 1.0F - mb[j] - ma[j] + both;
    const float sum = g0[j] + g1[j];
    const float t = both * ((13.0F * sum - gb[j] - ga[j]) * (1.0F / 24.0F)) +
                    before_only * ((-gb[j] + 8.0F * g0[j] + 5.0F * g1[j]) * (1.0F / 12.0F)) +
                    after_only * ((5.0F * g0[j] + 8.0F * g1[j] - ga[j]) * (1.0F / 12.0F)) +
                    neither * (0.5F * sum);
    const float e = m0[j] * m1[j];
    weight[j] = e;
    target[j] = e * t;
  }
}

// The finest level's packed byte for one row (Level): ex[j + 1] is the
// edge from j to j + 1 (ex[0] = 0), ey the edges down, ey_above those from
// the row above down to this one.
PSRIG_VECTOR_CLONES
void pack_edges(const float* __restrict ex, const float* __restrict ey,
                const float* __restrict ey_above, std::uint8_t* __restrict edges, int w) {
  for (int j = 0; j < w; ++j) {
    const auto right = static_cast<unsigned>(ex[j + 1]);
    const auto down = static_cast<unsigned>(ey[j]);
    const unsigned degree =
        right + down + static_cast<unsigned>(ex[j]) + static_cast<unsigned>(ey_above[j]);
    edges[j] = static_cast<std::uint8_t>(right | (down << 1U) | (degree << 2U));
  }
}

// The domain: inside the mask, with finite gradients.
cv::Mat integration_domain(const cv::Mat& p, const cv::Mat& q, const cv::Mat& mask) {
  const int w = p.cols;
  const int h = p.rows;
  cv::Mat inside(h, w, CV_8U);
  parallel_chunks(h, kRowsPerChunk, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      const float* pr = p.ptr<float>(i);
      const float* qr = q.ptr<float>(i);
      const std::uint8_t* mr = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(i);
      std::uint8_t* out = inside.ptr<std::uint8_t>(i);
      for (int j = 0; j < w; ++j)
        out[j] = (mr == nullptr || mr[j] != 0) && is_finite(pr[j]) && is_finite(qr[j]) ? 1 : 0;
    }
  });
  return inside;
}

// Edge weights and the right-hand side b for rows [begin, end), a row at a
// time: b_i = sum over i's edges of the target difference toward i. `edges`
// and `b` are the whole grid's (Level's packed bytes).
void assemble_rows(const cv::Mat& p, const cv::Mat& q, const cv::Mat& inside, float limit,
                   int begin, int end, std::uint8_t* edges, float* b) {
  const int w = p.cols;
  const int h = p.rows;
  const auto width = static_cast<std::size_t>(w);
  // Row buffers with one sample of zeros before and two after, so that
  // every edge sees four samples: gradients (0 outside) and inside (1/0).
  std::vector<float> g_row(width + 3, 0.0F);
  std::vector<float> m_row(width + 3, 0.0F);
  std::vector<float> g_rows[4];
  std::vector<float> m_rows[4];
  for (int k = 0; k < 4; ++k) {
    g_rows[k].assign(width, 0.0F);
    m_rows[k].assign(width, 0.0F);
  }
  std::vector<float> gx(width + 1, 0.0F);  // gx[j + 1]: edge j to j + 1; gx[0] = 0
  std::vector<float> ex(width + 1, 0.0F);
  std::vector<float> gy_above(width, 0.0F);
  std::vector<float> gy(width, 0.0F);
  std::vector<float> ey_above(width, 0.0F);
  std::vector<float> ey(width, 0.0F);
  const auto load = [&](const cv::Mat& g, int i, float* values, float* inside_row) {
    if (i < 0 || i >= h) {
      std::fill(values, values + width, 0.0F);
      std::fill(inside_row, inside_row + width, 0.0F);
      return;
    }
    load_row(g.ptr<float>(i), inside.ptr<std::uint8_t>(i), limit, values, inside_row, w);
  };
  // gy for the edges from row i down to row i + 1.
  const auto vertical = [&](int i, float* targets, float* weights) {
    for (int k = 0; k < 4; ++k)
      load(q, i - 1 + k, g_rows[k].data(), m_rows[k].data());
    edge_targets(g_rows[0].data(), g_rows[1].data(), g_rows[2].data(), g_rows[3].data(),
                 m_rows[0].data(), m_rows[1].data(), m_rows[2].data(), m_rows[3].data(), targets,
                 weights, w);
    for (std::size_t j = 0; j < width; ++j)
      targets[j] = -targets[j];  // y is up, the row index down
  };
  vertical(begin - 1, gy_above.data(), ey_above.data());
  for (int i = begin; i < end; ++i) {
    load(p, i, g_row.data() + 1, m_row.data() + 1);
    edge_targets(g_row.data(), g_row.data() + 1, g_row.data() + 2, g_row.data() + 3, m_row.data(),
                 m_row.data() + 1, m_row.data() + 2, m_row.data() + 3, gx.data() + 1, ex.data() + 1,
                 w);
    vertical(i, gy.data(), ey.data());
    const std::size_t row = static_cast<std::size_t>(i) * width;
    pack_edges(ex.data(), ey.data(), ey_above.data(), edges + row, w);
    for (std::size_t j = 0; j < width; ++j)
      b[row + j] = gx[j] - gx[j + 1] + gy_above[j] - gy[j];
    std::swap(gy_above, gy);
    std::swap(ey_above, ey);
  }
}

// Preconditioned conjugate gradients from zero, into `x` (w x h), for the
// finest level's system with right-hand side `b`. The search direction d
// and A d are updated together from z = M r in one pass:
// A (z + beta d) = A z + beta A d.
// The residual is built in b's buffer: fewer fresh pages for the kernel to
// clear.
MaskedIntegrationStats conjugate_gradients(Multigrid& multigrid, std::vector<float> b, float* x,
                                           int w, int h, const MaskedIntegrationOptions& options) {
  const Level& level = multigrid.finest();
  const std::size_t n = static_cast<std::size_t>(w) * h;
  const double b_norm = std::sqrt(dot(b, b, w, h));
  std::vector<float> r = std::move(b);
  std::vector<float> z(n, 0.0F);
  std::vector<float> d(n, 0.0F);
  std::vector<float> ad(n, 0.0F);
  int iterations = 0;
  double relative = 0.0;
  if (b_norm > 0) {
    double rz = multigrid.apply(r.data(), z.data());
    double dad = update_direction(level, z.data(), 0.0F, d.data(), ad.data());
    relative = 1.0;
    while (iterations < options.max_iterations) {
      if (!(dad > 0)) break;
      const auto alpha = static_cast<float>(rz / dad);
      const double r_norm2 = reduce(h, [&](int begin, int end) {
        return step_range(x, r.data(), d.data(), ad.data(), alpha,
                          static_cast<std::size_t>(begin) * w, static_cast<std::size_t>(end) * w);
      });
      const double next = std::sqrt(r_norm2) / b_norm;
      // In float, the recurrence's residual reaches a floor (a few 1e-7 of
      // |b| on small grids, 1e-5 at 12 MP) and then wanders off. Once near
      // it, a step that raises the residual is taken back and the solve ends.
      if (next > relative && relative < kFloorZone) {
        parallel_chunks(h, kRowsPerChunk, [&](int begin, int end) {
          for (std::size_t k = static_cast<std::size_t>(begin) * w;
               k < static_cast<std::size_t>(end) * w; ++k)
            x[k] -= alpha * d[k];
        });
        break;
      }
      ++iterations;
      relative = next;
      if (relative < options.tolerance) break;
      const double rz_next = multigrid.apply(r.data(), z.data());
      const auto beta = static_cast<float>(rz_next / rz);
      rz = rz_next;
      dad = update_direction(level, z.data(), beta, d.data(), ad.data());
    }
  }
  return {iterations, relative};
}

// The mean of `height` over each labelled piece (label 0, outside the
// domain, left at 0). Sums per piece: per chunk of rows when there are few
// pieces, combined in chunk order; serially for a lace of many.
std::vector<float> piece_means(const cv::Mat& labels, int pieces, const cv::Mat& height) {
  const int w = height.cols;
  const int h = height.rows;
  const float* const x = height.ptr<float>();
  const auto piece_count = static_cast<std::size_t>(pieces);
  std::vector<double> sum(piece_count, 0.0);
  std::vector<double> count(piece_count, 0.0);
  const auto add_rows = [&](int begin, int end, double* s, double* c) {
    for (int i = begin; i < end; ++i) {
      const int* lr = labels.ptr<int>(i);
      const float* xr = x + static_cast<std::size_t>(i) * w;
      for (int j = 0; j < w; ++j) {
        s[lr[j]] += xr[j];
        c[lr[j]] += 1.0;
      }
    }
  };
  if (piece_count <= 64) {
    const auto chunks = static_cast<std::size_t>(chunk_count(h, kRowsPerChunk));
    std::vector<double> partial(chunks * piece_count * 2, 0.0);
    parallel_chunks(h, kRowsPerChunk, [&](int begin, int end) {
      double* s =
          partial.data() + static_cast<std::size_t>(begin / kRowsPerChunk) * piece_count * 2;
      add_rows(begin, end, s, s + piece_count);
    });
    for (std::size_t chunk = 0; chunk < chunks; ++chunk)
      for (std::size_t piece = 0; piece < piece_count; ++piece) {
        sum[piece] += partial[chunk * piece_count * 2 + piece];
        count[piece] += partial[chunk * piece_count * 2 + piece_count + piece];
      }
  } else {
    add_rows(0, h, sum.data(), count.data());
  }
  std::vector<float> mean(static_cast<std::size_t>(pieces), 0.0F);
  for (std::size_t c = 1; c < mean.size(); ++c)
    mean[c] = static_cast<float>(sum[c] / count[c]);
  return mean;
}

// Each connected piece of the domain has its own free constant: give each
// zero mean, and NaN outside the domain.
void centre_pieces(const cv::Mat& inside, cv::Mat& height) {
  const int w = height.cols;
  cv::Mat labels;
  const int pieces = cv::connectedComponents(inside, labels, 4, CV_32S);
  const std::vector<float> mean = piece_means(labels, pieces, height);
  parallel_chunks(height.rows, kRowsPerChunk, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      const int* lr = labels.ptr<int>(i);
      float* out = height.ptr<float>(i);
      for (int j = 0; j < w; ++j)
        out[j] = lr[j] == 0 ? std::numeric_limits<float>::quiet_NaN()
                            : out[j] - mean[static_cast<std::size_t>(lr[j])];
    }
  });
}

// p and q are this function's own headers: when the caller handed over its
// only ones, their memory goes back as soon as the system is assembled.
Result<cv::Mat> solve_masked(cv::Mat p, cv::Mat q, const cv::Mat& mask,
                             const MaskedIntegrationOptions& options,
                             MaskedIntegrationStats* stats) {
  const int w = p.cols;
  const int h = p.rows;
  const std::size_t n = static_cast<std::size_t>(w) * h;
  const cv::Mat inside = integration_domain(p, q, mask);

  // The solution is built in the result's own buffer: fewer fresh pages for
  // the kernel to clear.
  cv::Mat height(h, w, CV_32F, cv::Scalar(0));
  {
    Level fine;
    fine.w = w;
    fine.h = h;
    fine.edges.assign(n, 0);
    std::vector<float> b(n, 0.0F);
    parallel_chunks(h, kRowsPerChunk, [&](int begin, int end) {
      assemble_rows(p, q, inside, options.max_slope, begin, end, fine.edges.data(), b.data());
    });
    p.release();
    q.release();
    give_back_free_memory();  // what p and q held: none of it kept idle beside the solve's own
    Multigrid multigrid(std::move(fine));
    const MaskedIntegrationStats solved =
        conjugate_gradients(multigrid, std::move(b), height.ptr<float>(), w, h, options);
    if (stats != nullptr) *stats = solved;
  }  // the hierarchy goes before the pieces are labelled
  centre_pieces(inside, height);
  return height;
}

Result<cv::Mat> checked_solve(cv::Mat p, cv::Mat q, const cv::Mat& mask,
                              const MaskedIntegrationOptions& options,
                              MaskedIntegrationStats* stats) {
  try {
    if (auto checked = check_gradient_inputs(p, q); !checked)
      return std::unexpected(checked.error());
    if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != p.size()))
      return std::unexpected(
          bad_input({}, {},
                    "integration: the mask must be one 8-bit channel the size of p and q (" +
                        std::to_string(p.cols) + "x" + std::to_string(p.rows) + "), got " +
                        cv::typeToString(mask.type()) + " " + std::to_string(mask.cols) + "x" +
                        std::to_string(mask.rows)));
    if (!(options.max_slope > 0))
      return std::unexpected(bad_input({}, {}, "integration: max_slope must be positive"));
    if (!(options.tolerance > 0) || options.max_iterations < 0)
      return std::unexpected(bad_input(
          {}, {}, "integration: tolerance must be positive and max_iterations not negative"));
    return solve_masked(std::move(p), std::move(q), mask, options, stats);
  } catch (const std::exception& e) {
    return std::unexpected(internal_error(std::string("integration: ") + e.what()));
  }
}

}  // namespace

Result<cv::Mat> integrate_masked(const cv::Mat& p, const cv::Mat& q, const cv::Mat& mask,
                                 const MaskedIntegrationOptions& options,
                                 MaskedIntegrationStats* stats) {
  return checked_solve(p, q, mask, options, stats);
}

Result<cv::Mat> integrate_masked(cv::Mat&& p, cv::Mat&& q, const cv::Mat& mask,
                                 const MaskedIntegrationOptions& options,
                                 MaskedIntegrationStats* stats) {
  return checked_solve(std::move(p), std::move(q), mask, options, stats);
}

}  // namespace psrig::processing
