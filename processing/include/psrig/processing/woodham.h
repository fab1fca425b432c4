#pragma once
// Woodham's photometric stereo (Woodham 1980, as used by Robb et al. 2003):
// per pixel, i = rho L n for the lights' measurements i. The scaled normal is
// t = L^-1 i (three lights) or the least-squares (L^T L)^-1 L^T i (more),
// rho = |t|, p = -t1/t3, q = -t2/t3. Colour scans get one normal per pixel,
// from the mean of the channels, and an albedo per channel: the least-squares
// rho_c with that normal fixed.

#include <cstdint>
#include <memory>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/formats/light_matrix.h"
#include "psrig/formats/scan.h"
#include "psrig/processing/linearise.h"

namespace psrig::processing {

// Why a pixel's result is doubtful, as bits of SolveResult::flags.
enum PixelFlag : std::uint8_t {
  kOutsideMask = 1 << 0,  // the scan's mask excludes it: not solved
  kSaturated = 1 << 1,    // some measurement at or above the white level
  kShadowed = 1 << 2,     // some measurement below shadow_ratio * albedo (attached or cast shadow)
  kLowSignal = 1 << 3,    // even the brightest measurement is below low_signal: not solved
  kNoSolution = 1 << 4,   // the scaled normal points into the swatch or vanishes: not solved
  kRecovered = 1 << 5,  // rejection dropped measurements (shadowed, saturated, off the fit), solved
                        // from the rest
  kHighlight =
      1 << 6,  // rejection dropped unsaturated measurements brighter than the fit (highlights)
};

// A pixel is valid (mask.png) when nothing doubtful is left about it.
[[nodiscard]] inline bool is_valid(std::uint8_t flags) {
  constexpr std::uint8_t kUnsolved = kOutsideMask | kLowSignal | kNoSolution;
  if (flags & kUnsolved) return false;
  return (flags & kRecovered) || !(flags & (kSaturated | kShadowed));
}

struct SolveOptions {
  // Four or more lights: drop each pixel's saturated and shadowed
  // measurements and its unsaturated highlights before solving, when at
  // least three well-spread remain (reject_method below).
  bool reject_outliers = false;
  // A measurement below this fraction of the pixel's albedo is shadowed:
  // l.n below 0.05 means the light grazes past 87 degrees or is blocked.
  float shadow_ratio = 0.05f;
  // Pixels whose brightest measurement is below this fraction of full scale
  // carry too little signal to solve.
  float low_signal = 0.01f;
  // Solve three lights by per-pixel least squares instead of the exact
  // inverse (the two must agree; tests compare them).
  bool force_least_squares = false;
};

// What outlier rejection does, as report.json's options.reject_method
// says: "none" without it, or with three lights, where nothing can go;
// "lts-reweighted" with it: per pixel, saturated measurements out, then
// least trimmed squares started from the values left after dropping the
// darkest quarter and the brightest sixth, and reweighted least squares
// that drops every measurement (cast or attached shadow, unsaturated
// highlight) off the fit by more than 2.5 robust sigmas (Rousseeuw & Leroy,
// "Robust Regression and Outlier Detection", 1987; woodham.cpp says more).
[[nodiscard]] const char* reject_method(const SolveOptions& options, int lights);

struct SolveResult {
  cv::Mat p;         // CV_32F, dz/dx; 0 where not solved
  cv::Mat q;         // CV_32F, dz/dy (y up); 0 where not solved
  cv::Mat albedo;    // CV_32FC(channels), BGR for colour; 0 where not solved
  cv::Mat residual;  // CV_32F, RMS misfit of the Lambertian model, fraction of full scale
  cv::Mat flags;     // CV_8U, PixelFlag bits
};

// A scan's solve prepared once (its linearisation, the light matrix) and run
// a band of rows at a time: the pipeline makes each band's maps as soon as it
// is solved, and never holds the whole albedo. Holds a reference to the scan:
// it must not outlive it or see it move.
class RowSolver {
 public:
  [[nodiscard]] static Result<RowSolver> create(const formats::Scan& scan,
                                                const SolveOptions& options = {});
  // Rows [first, first + rows) of the scan into `out`, a row at a time on the
  // thread pool; out's planes are made `rows` high unless they already are
  // (views into larger planes stay views). The same values as solve().
  void solve(int first, int rows, SolveResult& out) const;

  RowSolver(RowSolver&&) noexcept;
  RowSolver& operator=(RowSolver&&) noexcept;
  ~RowSolver();

 private:
  struct Setup;
  explicit RowSolver(std::unique_ptr<Setup> setup);
  std::unique_ptr<Setup> setup_;
};

// Linearises and solves a whole scan, a row at a time on the thread pool.
[[nodiscard]] Result<SolveResult> solve(const formats::Scan& scan,
                                        const SolveOptions& options = {});
// The same into `result`, reusing its buffers when they have the right size.
[[nodiscard]] Status solve_into(const formats::Scan& scan, const SolveOptions& options,
                                SolveResult& result);

// Unit normals (nx, ny, nz) from gradients, CV_32FC3.
[[nodiscard]] cv::Mat normals_from_gradients(const cv::Mat& p, const cv::Mat& q);

// Solve flags -> CV_8U, 255 where the pixel is valid, 0 elsewhere.
[[nodiscard]] cv::Mat encode_valid_mask(const cv::Mat& flags);

}  // namespace psrig::processing
