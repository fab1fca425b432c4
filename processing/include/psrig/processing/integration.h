#pragma once
// Normal integration: a height map from the gradient maps p = dz/dx and
// q = dz/dy (docs/design.md "Axes and units": x to the image's right, y to its top, so q is
// minus the derivative along the row index). Heights come out in the units
// of the grid spacing, i.e. pixels; the caller scales by pixel_size_mm.
// Both methods fix the free constant by giving the result zero mean.

#include <limits>
#include <optional>
#include <string_view>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"

namespace psrig::processing {

enum class IntegrationMethod { frankot_chellappa, poisson, none };

// "fc" | "poisson" | "none".
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

// Dispatches on method; `none` returns an empty Mat.
[[nodiscard]] Result<cv::Mat> integrate(IntegrationMethod method, const cv::Mat& p,
                                        const cv::Mat& q, float max_slope = kNoSlopeLimit);

}  // namespace psrig::processing
