#pragma once
// Normal integration: a height map from the gradient maps p = dz/dx and
// q = dz/dy (docs/design.md "Axes and units": x to the image's right, y to its top, so q is
// minus the derivative along the row index). Heights come out in the units
// of the grid spacing, i.e. pixels; the caller scales by pixel_size_mm.
// Frankot–Chellappa and Poisson integrate the whole rectangle and fix the free
// constant by giving the result zero mean; the masked least-squares solver
// integrates only the pixels inside a mask (see integrate_masked).

#include <limits>
#include <optional>
#include <string_view>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"

namespace psrig::processing {

// automatic: masked where the input has a mask that leaves pixels out, or
// non-finite gradients (holes); Frankot–Chellappa otherwise.
enum class IntegrationMethod { frankot_chellappa, poisson, masked, automatic, none };

// "fc" | "poisson" | "masked" | "auto" | "none".
[[nodiscard]] std::optional<IntegrationMethod> parse_integration_method(std::string_view name);
[[nodiscard]] std::string_view to_string(IntegrationMethod method);

// Frankot–Chellappa: the integrable surface nearest to (p, q) in the Fourier
// domain, with the gradient field extended by mirroring (z even about every
// border, so p and q are odd across the borders they cross) so the periodic
// transform sees no wrap-around jump. Implemented with FFTW r2r transforms of
// the un-extended size, which is the same computation.
// p, q: CV_32F, same size; non-finite values (unsolved pixels) count as 0,
// and values beyond +-max_slope are clamped to it, so that a few wild
// pixels cannot tilt the whole surface. Returns CV_32F.
inline constexpr float kNoSlopeLimit = std::numeric_limits<float>::max();
[[nodiscard]] Result<cv::Mat> integrate_frankot_chellappa(const cv::Mat& p, const cv::Mat& q,
                                                          float max_slope = kNoSlopeLimit);

// Least-squares Poisson solve of the discrete problem with Neumann
// boundaries, diagonalised by the DCT. Same contract as above.
[[nodiscard]] Result<cv::Mat> integrate_poisson(const cv::Mat& p, const cv::Mat& q,
                                                float max_slope = kNoSlopeLimit);

// Routes FFTW's threads into the process's pool, once; true when FFTW has
// thread support. The integrators call it themselves; code calling FFTW
// directly (benchmarks) calls it before planning.
bool prepare_fftw_threads();

// Least squares over a mask: minimises, over every pair of 4-neighbours both
// inside the mask, (z[i][j+1] - z[i][j] - gx)^2 and (z[i+1][j] - z[i][j] -
// gy)^2, where gx integrates p from one pixel to the next and gy integrates
// -q (y is up). The Poisson solver's energy restricted to the mask, except
// that the integral along an edge is taken to fourth order from the samples
// around it, (-p[j-1] + 13 p[j] + 13 p[j+1] - p[j+2]) / 24 (third order,
// from three samples, where the mask cuts one off; the trapezoid between two
// lone samples). Pixels with a non-finite p or q count as outside. Solved by
// conjugate gradients preconditioned with a multigrid V-cycle until the
// normal equations' residual falls below `tolerance` times the right-hand
// side's (or after max_iterations).
// mask: CV_8UC1, the size of p and q, nonzero = inside; empty = every pixel.
// Returns CV_32F: NaN outside the domain; each 4-connected piece of the
// domain has its own free constant and is given zero mean.
struct MaskedIntegrationOptions {
  float max_slope = kNoSlopeLimit;
  double tolerance = 1e-5;
  int max_iterations = 200;
};
struct MaskedIntegrationStats {
  int iterations = 0;
  double relative_residual = 0;  // |b - A z| / |b| at the end
};
[[nodiscard]] Result<cv::Mat> integrate_masked(const cv::Mat& p, const cv::Mat& q,
                                               const cv::Mat& mask,
                                               const MaskedIntegrationOptions& options = {},
                                               MaskedIntegrationStats* stats = nullptr);
// The same, handed p and q (moved in): when those were their only headers,
// their memory goes back as soon as the system is assembled, before the
// solver's own is taken (96 MB at 12 MP: the pipeline's peak).
[[nodiscard]] Result<cv::Mat> integrate_masked(cv::Mat&& p, cv::Mat&& q, const cv::Mat& mask,
                                               const MaskedIntegrationOptions& options = {},
                                               MaskedIntegrationStats* stats = nullptr);

// Whether `automatic` chooses the masked solver for this input: the mask
// (if any) leaves a pixel out, or a gradient is not finite.
[[nodiscard]] bool needs_masked_integration(const cv::Mat& p, const cv::Mat& q,
                                            const cv::Mat& mask = {});

// Dispatches on method; `none` returns an empty Mat. The mask (CV_8UC1 or
// empty) is used by `masked` and `automatic`; fc and poisson integrate the
// whole rectangle with non-finite gradients as 0 and ignore it.
[[nodiscard]] Result<cv::Mat> integrate(IntegrationMethod method, const cv::Mat& p,
                                        const cv::Mat& q, float max_slope = kNoSlopeLimit);
[[nodiscard]] Result<cv::Mat> integrate(IntegrationMethod method, const cv::Mat& p,
                                        const cv::Mat& q, const cv::Mat& mask,
                                        float max_slope = kNoSlopeLimit);

}  // namespace psrig::processing
