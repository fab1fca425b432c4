#include "psrig/processing/integration.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <memory>
#include <mutex>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <fftw3.h>

#include "gradient_inputs.h"
#include "psrig/base/parallel.h"

// Both methods work on the gradient field extended by mirroring across every
// border (z even about the half-pixel beyond the first and last sample), so
// the spectral solve sees a smooth periodic field instead of the wrap-around
// jump of a plain FFT. On such a field the periodic 2W x 2H Fourier transform
// reduces to FFTW's real-to-real transforms of the W x H field:
//   z, even in x and y   -> REDFT10 (DCT-II) along both axes,
//   p, odd in x, even y  -> RODFT10 (DST-II) along x, REDFT10 along y,
//   q, even in x, odd y  -> REDFT10 along x, RODFT10 along y,
// which costs a quarter of the literal extended FFT.
// References: R. T. Frankot, R. Chellappa, "A method for enforcing
// integrability in shape from shading algorithms", IEEE PAMI 10(4), 1988;
// T. Simchony, R. Chellappa, M. Shao, "Direct analytical methods for solving
// Poisson equations in computer vision problems", IEEE PAMI 12(5), 1990 (the
// DCT Poisson solver); Y. Queau, J.-D. Durou, J.-F. Aujol, "Normal
// integration: a survey", JMIV 60, 2018 (the mirror extension).

namespace psrig::processing {
namespace {

// ---------------------------------------------------------------------------
// FFTW glue: one planner lock, FFTW's threads routed into the process's pool.

// FFTW's parallel loops run through parallel_chunks, so `--threads N` bounds
// them like every other loop. noexcept: an exception must not unwind through
// FFTW's C frames.
void run_fftw_jobs(void* (*work)(char*), char* job_data, std::size_t job_size, int jobs,
                   void* /*data*/) noexcept {
  parallel_chunks(jobs, 1, [&](int begin, int end) {
    for (int job = begin; job < end; ++job)
      work(job_data + job_size * static_cast<std::size_t>(job));
  });
}

// FFTW's planner is not thread-safe: every plan create and destroy holds this.
std::mutex& planner_mutex() {
  static std::mutex mutex;
  return mutex;
}

struct FftwFree {
  void operator()(float* data) const { fftwf_free(data); }
};
using FftwBuffer = std::unique_ptr<float[], FftwFree>;

struct PlanDestroy {
  void operator()(fftwf_plan plan) const {
    std::lock_guard lock(planner_mutex());
    fftwf_destroy_plan(plan);
  }
};
using Plan = std::unique_ptr<fftwf_plan_s, PlanDestroy>;

// An in-place 2-D r2r plan over a height x width row-major buffer. Planned
// with FFTW_ESTIMATE: FFTW_MEASURE chooses between plans by timing them, so
// its results could differ from run to run; ESTIMATE also leaves the buffer
// untouched, so data may already be in it.
Plan make_plan(int width, int height, fftw_r2r_kind kind_x, fftw_r2r_kind kind_y, float* buffer) {
  const bool threads = prepare_fftw_threads();
  std::lock_guard lock(planner_mutex());
  if (threads) fftwf_plan_with_nthreads(thread_count());
  return Plan(fftwf_plan_r2r_2d(height, width, buffer, buffer, kind_y, kind_x, FFTW_ESTIMATE));
}

// Runs one transform in place, planning it first.
Status transform(float* buffer, int width, int height, fftw_r2r_kind kind_x, fftw_r2r_kind kind_y) {
  const Plan plan = make_plan(width, height, kind_x, kind_y, buffer);
  if (!plan) return std::unexpected(internal_error("integration: FFTW could not plan a transform"));
  fftwf_execute(plan.get());
  return {};
}

// ---------------------------------------------------------------------------
// Data-parallel helpers. Work is split into fixed blocks of rows, chosen from
// the width alone, so results never depend on the thread count.

constexpr int kChunkElements = 1 << 16;
int rows_per_chunk(int width) {
  return std::max(1, kChunkElements / std::max(1, width));
}

// Non-finite gradients (unsolved or masked pixels) count as flat; one NaN
// would otherwise spread over the whole spectrum. Tests the exponent bits:
// integer masks vectorise where a float compare with NaN (which may trap)
// keeps GCC from if-converting some loops.
inline float finite_or_zero(float value) {
  const auto bits = std::bit_cast<std::uint32_t>(value);
  const std::uint32_t keep = (bits & 0x7F800000U) == 0x7F800000U ? 0U : ~0U;
  return std::bit_cast<float>(bits & keep);
}

// A gradient as the solvers take it: finite, and within +-limit.
inline float gradient_value(float value, float limit) {
  return std::clamp(finite_or_zero(value), -limit, limit);
}


// Sum of rows [begin, end) of a row-major buffer, in double. Eight
// accumulators in a fixed order keep it fast and reproducible.
double sum_rows(const float* data, int width, int begin, int end) {
  constexpr std::size_t kLanes = 8;
  const float* values = data + static_cast<std::size_t>(begin) * width;
  const std::size_t count = static_cast<std::size_t>(end - begin) * width;
  double lanes[kLanes] = {};
  std::size_t i = 0;
  for (; i + kLanes <= count; i += kLanes)
    for (std::size_t lane = 0; lane < kLanes; ++lane)
      lanes[lane] += values[i + lane];
  double total = 0.0;
  for (double lane : lanes)
    total += lane;
  for (; i < count; ++i)
    total += values[i];
  return total;
}

// Removes the mean in place. The spectral solve already zeroes the DC term;
// this removes what rounding left.
void remove_mean(cv::Mat& z) {
  const int width = z.cols;
  const int height = z.rows;
  float* data = z.ptr<float>();
  const int chunk = rows_per_chunk(width);
  std::vector<double> sums(static_cast<std::size_t>(chunk_count(height, chunk)), 0.0);
  parallel_chunks(height, chunk, [&](int begin, int end) {
    sums[static_cast<std::size_t>(begin / chunk)] = sum_rows(data, width, begin, end);
  });
  double total = 0.0;
  for (double sum : sums)
    total += sum;  // chunk order: the same for any thread count
  const auto mean = static_cast<float>(total / (static_cast<double>(width) * height));
  parallel_chunks(height, chunk, [&](int begin, int end) {
    float* values = data + static_cast<std::size_t>(begin) * width;
    const std::size_t count = static_cast<std::size_t>(end - begin) * width;
    for (std::size_t i = 0; i < count; ++i)
      values[i] -= mean;
  });
}

// -4 sin^2(pi k / (2 n)) = 2 cos(pi k / n) - 2, the eigenvalues of the 1-D
// Neumann second difference; the sine form keeps low frequencies accurate.
std::vector<float> neumann_eigenvalues(int n) {
  std::vector<float> values(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    const double half = std::sin(std::numbers::pi * k / (2.0 * n));
    values[static_cast<std::size_t>(k)] = static_cast<float>(-4.0 * half * half);
  }
  return values;
}

// ---------------------------------------------------------------------------
// Frankot–Chellappa.

Result<cv::Mat> frankot_chellappa(const cv::Mat& p, const cv::Mat& q, int width, int height,
                                  float limit) {
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  // The result doubles as the work buffer for p, then Z, then z: one large
  // allocation fewer and no copy out. A new cv::Mat is continuous (and
  // 64-byte aligned; plans are made on the buffer itself, so FFTW adapts to
  // whatever alignment it has).
  cv::Mat z(height, width, CV_32FC1);
  float* const a = z.ptr<float>();
  const FftwBuffer b(fftwf_alloc_real(pixels));  // q
  if (!b) return std::unexpected(internal_error("integration: out of memory"));

  const int chunk = rows_per_chunk(width);
  parallel_chunks(height, chunk, [&](int begin, int end) {
    for (int row = begin; row < end; ++row) {
      const auto* p_row = p.ptr<float>(row);
      const auto* q_row = q.ptr<float>(row);
      float* a_row = a + static_cast<std::size_t>(row) * width;
      float* b_row = b.get() + static_cast<std::size_t>(row) * width;
      for (int col = 0; col < width; ++col) {
        a_row[col] = gradient_value(p_row[col], limit);
        b_row[col] = gradient_value(q_row[col], limit);
      }
    }
  });

  // A[l][k-1]: x frequency k = 1..W (DST-II index k-1), y frequency l.
  if (auto status = transform(a, width, height, FFTW_RODFT10, FFTW_REDFT10); !status)
    return std::unexpected(status.error());
  // B[l-1][k]: x frequency k, y frequency l = 1..H. B is the transform of q,
  // and the derivative along the row index is g = -q.
  if (auto status = transform(b.get(), width, height, FFTW_REDFT10, FFTW_RODFT10); !status)
    return std::unexpected(status.error());

  // With u_k = pi k / W, v_l = pi l / H, the spectral derivative of the
  // even-extended z is A[l][k-1] = -u_k Z[l][k] and B_g[l-1][k] = -v_l Z[l][k]
  // (1-D: d/dx of C_k cos(u_k (x + 1/2)) is -u_k C_k sin(u_k (x + 1/2))).
  // Least squares over both, per frequency (Frankot & Chellappa):
  //   Z = -(u A + v B_g) / (u^2 + v^2) = (-u A + v B) / (u^2 + v^2),
  // Z[0][0] = 0 (zero mean). The Nyquist terms A[l][W-1] (k = W) and
  // B[H-1][k] (l = H) have no DCT-II partner: the mirror-extended z has a zero
  // coefficient there, so they are dropped. The inverse REDFT01 gains 4WH,
  // folded in here as `scale`.
  const double scale = 1.0 / (4.0 * static_cast<double>(pixels));
  std::vector<float> weight_x(static_cast<std::size_t>(width));  // -scale u_k
  std::vector<float> u_squared(static_cast<std::size_t>(width));
  for (int k = 0; k < width; ++k) {
    const double u = std::numbers::pi * k / width;
    weight_x[static_cast<std::size_t>(k)] = static_cast<float>(-scale * u);
    u_squared[static_cast<std::size_t>(k)] = static_cast<float>(u * u);
  }
  parallel_chunks(height, chunk, [&](int begin, int end) {
    // A row shifted right by one, so that column k holds A[l][k-1] and the
    // loop below runs over aligned columns (and may overwrite A's row).
    std::vector<float> shifted(static_cast<std::size_t>(width), 0.0F);
    const float* wx = weight_x.data();
    const float* uu = u_squared.data();
    float* sh = shifted.data();
    for (int l = begin; l < end; ++l) {
      float* z_row = a + static_cast<std::size_t>(l) * width;
      std::copy(z_row, z_row + width - 1, sh + 1);
      if (l == 0) {
        z_row[0] = 0.0F;
        for (int k = 1; k < width; ++k)
          z_row[k] = wx[k] * sh[k] / uu[k];
        continue;
      }
      const double v = std::numbers::pi * l / height;
      const auto weight_y = static_cast<float>(scale * v);
      const auto v_squared = static_cast<float>(v * v);
      const float* b_row = b.get() + static_cast<std::size_t>(l - 1) * width;
      for (int k = 0; k < width; ++k)
        z_row[k] = (wx[k] * sh[k] + weight_y * b_row[k]) / (uu[k] + v_squared);
    }
  });

  if (auto status = transform(a, width, height, FFTW_REDFT01, FFTW_REDFT01); !status)
    return std::unexpected(status.error());
  remove_mean(z);
  return z;
}

// ---------------------------------------------------------------------------
// Poisson.

// Right-hand side of the normal equations for one row: the backward
// difference of the half-pixel averages pbar (along x) and gbar, g = -q
// (along the row index), each taken as zero outside the grid. In the
// interior this is the central difference (p[j+1] - p[j-1]) / 2 +
// (q[i-1] - q[i+1]) / 2.
// (__restrict: f is a separate buffer, which lets the loops vectorise.)
void poisson_rhs_row(const float* __restrict p_row, const float* __restrict q_prev,
                     const float* __restrict q_row, const float* __restrict q_next,
                     float* __restrict f, int width, int row, int height, float limit) {
  if (width == 1) {
    f[0] = 0.0F;
  } else {
    f[0] = 0.5F * (gradient_value(p_row[0], limit) + gradient_value(p_row[1], limit));
    for (int j = 1; j < width - 1; ++j)
      f[j] = 0.5F * (gradient_value(p_row[j + 1], limit) - gradient_value(p_row[j - 1], limit));
    f[width - 1] =
        -0.5F * (gradient_value(p_row[width - 2], limit) + gradient_value(p_row[width - 1], limit));
  }
  if (height == 1) return;
  if (row == 0) {  // gbar[0] only
    for (int j = 0; j < width; ++j)
      f[j] -= 0.5F * (gradient_value(q_row[j], limit) + gradient_value(q_next[j], limit));
  } else if (row == height - 1) {  // -gbar[H-2] only
    for (int j = 0; j < width; ++j)
      f[j] += 0.5F * (gradient_value(q_prev[j], limit) + gradient_value(q_row[j], limit));
  } else {
    for (int j = 0; j < width; ++j)
      f[j] += 0.5F * (gradient_value(q_prev[j], limit) - gradient_value(q_next[j], limit));
  }
}

// Minimises sum (z[i][j+1] - z[i][j] - pbar)^2 + (z[i+1][j] - z[i][j] - gbar)^2.
// The normal equations are the 5-point Laplacian with Neumann boundaries
// (mirror about the half-pixel) = divergence of (pbar, gbar), which the
// DCT-II diagonalises (Simchony, Chellappa & Shao 1990).
Result<cv::Mat> poisson(const cv::Mat& p, const cv::Mat& q, int width, int height, float limit) {
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  // The result doubles as the work buffer (see frankot_chellappa).
  cv::Mat z(height, width, CV_32FC1);
  float* const f = z.ptr<float>();

  const int chunk = rows_per_chunk(width);
  parallel_chunks(height, chunk, [&](int begin, int end) {
    for (int row = begin; row < end; ++row) {
      const auto* q_row = q.ptr<float>(row);
      const float* q_prev = row > 0 ? q.ptr<float>(row - 1) : q_row;
      const float* q_next = row + 1 < height ? q.ptr<float>(row + 1) : q_row;
      poisson_rhs_row(p.ptr<float>(row), q_prev, q_row, q_next,
                      f + static_cast<std::size_t>(row) * width, width, row, height, limit);
    }
  });

  if (auto status = transform(f, width, height, FFTW_REDFT10, FFTW_REDFT10); !status)
    return std::unexpected(status.error());

  // Eigenvalue of the Neumann Laplacian at (k, l): lx[k] + ly[l] < 0 except
  // at DC, which is the free constant: set to zero (zero mean).
  const auto scale = static_cast<float>(1.0 / (4.0 * static_cast<double>(pixels)));
  const std::vector<float> lambda_x = neumann_eigenvalues(width);
  const std::vector<float> lambda_y = neumann_eigenvalues(height);
  parallel_chunks(height, chunk, [&](int begin, int end) {
    const float* lx = lambda_x.data();
    for (int l = begin; l < end; ++l) {
      float* row = f + static_cast<std::size_t>(l) * width;
      const float ly = lambda_y[static_cast<std::size_t>(l)];
      const int first = l == 0 ? 1 : 0;
      if (l == 0) row[0] = 0.0F;
      for (int k = first; k < width; ++k)
        row[k] = scale * row[k] / (lx[k] + ly);
    }
  });

  if (auto status = transform(f, width, height, FFTW_REDFT01, FFTW_REDFT01); !status)
    return std::unexpected(status.error());
  remove_mean(z);
  return z;
}

using Method = Result<cv::Mat> (*)(const cv::Mat&, const cv::Mat&, int, int, float);

// Validates, then runs; never lets an exception (say, out of memory) escape.
Result<cv::Mat> run(Method method, const cv::Mat& p, const cv::Mat& q, float max_slope) {
  try {
    const auto size = check_gradient_inputs(p, q);
    if (!size) return std::unexpected(size.error());
    if (!(max_slope > 0))
      return std::unexpected(bad_input({}, {}, "integration: max_slope must be positive"));
    return method(p, q, size->width, size->height, max_slope);
  } catch (const std::exception& e) {
    return std::unexpected(internal_error(std::string("integration: ") + e.what()));
  }
}

}  // namespace

bool prepare_fftw_threads() {
  static std::once_flag once;
  static bool ready = false;
  std::call_once(once, [] {
    std::lock_guard lock(planner_mutex());
    ready = fftwf_init_threads() != 0;
    if (ready) fftwf_threads_set_callback(&run_fftw_jobs, nullptr);
  });
  return ready;
}

std::optional<IntegrationMethod> parse_integration_method(std::string_view name) {
  if (name == "fc") return IntegrationMethod::frankot_chellappa;
  if (name == "poisson") return IntegrationMethod::poisson;
  if (name == "masked") return IntegrationMethod::masked;
  if (name == "auto") return IntegrationMethod::automatic;
  if (name == "none") return IntegrationMethod::none;
  return std::nullopt;
}

std::string_view to_string(IntegrationMethod method) {
  switch (method) {
    case IntegrationMethod::frankot_chellappa:
      return "fc";
    case IntegrationMethod::poisson:
      return "poisson";
    case IntegrationMethod::masked:
      return "masked";
    case IntegrationMethod::automatic:
      return "auto";
    case IntegrationMethod::none:
      return "none";
  }
  return "unknown";
}

Result<cv::Mat> integrate_frankot_chellappa(const cv::Mat& p, const cv::Mat& q, float max_slope) {
  return run(&frankot_chellappa, p, q, max_slope);
}

Result<cv::Mat> integrate_poisson(const cv::Mat& p, const cv::Mat& q, float max_slope) {
  return run(&poisson, p, q, max_slope);
}

bool needs_masked_integration(const cv::Mat& p, const cv::Mat& q, const cv::Mat& mask) {
  if (!mask.empty() && cv::countNonZero(mask) < mask.rows * mask.cols) return true;
  for (const cv::Mat* m : {&p, &q}) {
    if (m->empty() || m->type() != CV_32FC1) continue;
    bool any = false;
    std::mutex lock;
    parallel_chunks(m->rows, rows_per_chunk(m->cols), [&](int begin, int end) {
      bool found = false;
      for (int row = begin; row < end && !found; ++row) {
        const auto* values = m->ptr<float>(row);
        for (int col = 0; col < m->cols; ++col)
          found |= (std::bit_cast<std::uint32_t>(values[col]) & 0x7F800000U) == 0x7F800000U;
      }
      if (found) {
        const std::lock_guard guard(lock);
        any = true;
      }
    });
    if (any) return true;
  }
  return false;
}

Result<cv::Mat> integrate(IntegrationMethod method, const cv::Mat& p, const cv::Mat& q,
                          float max_slope) {
  return integrate(method, p, q, cv::Mat(), max_slope);
}

Result<cv::Mat> integrate(IntegrationMethod method, const cv::Mat& p, const cv::Mat& q,
                          const cv::Mat& mask, float max_slope) {
  if (method == IntegrationMethod::automatic)
    method = needs_masked_integration(p, q, mask) ? IntegrationMethod::masked
                                                  : IntegrationMethod::frankot_chellappa;
  switch (method) {
    case IntegrationMethod::frankot_chellappa:
      return integrate_frankot_chellappa(p, q, max_slope);
    case IntegrationMethod::poisson:
      return integrate_poisson(p, q, max_slope);
    case IntegrationMethod::masked: {
      MaskedIntegrationOptions options;
      options.max_slope = max_slope;
      return integrate_masked(p, q, mask, options);
    }
    case IntegrationMethod::automatic:
    case IntegrationMethod::none:
      return cv::Mat();
  }
  return std::unexpected(internal_error("integration: unknown method"));
}

}  // namespace psrig::processing
