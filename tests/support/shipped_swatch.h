#pragma once
// The simulated swatches tests and benchmarks make: a shipped pattern by
// name (config/patterns, or an alias: jersey, rib, garter, plain, twill) and
// the swatch or synthetic scan of it. Header-only: only the programs that
// link psrig_sim (and psrig_capture) include it. A failure is a test's
// setup gone wrong: it throws with the error's description, which
// GoogleTest and Google Benchmark report.

#include <stdexcept>
#include <string_view>

#include "psrig/base/error.h"
#include "psrig/sim/swatch_model.h"

namespace psrig::test {

// The value, or an exception naming what went wrong.
template <class T>
T made(Result<T> result) {
  if (!result) throw std::runtime_error(result.error().describe());
  return std::move(*result);
}

inline sim::SwatchPattern named_pattern(std::string_view name) {
  return made(sim::load_swatch_pattern(name));
}

// `name`'s swatch of `size` pixels of `px` mm.
inline sim::SwatchParams swatch_params(std::string_view name, cv::Size size = {640, 480},
                                       double px = 0.025, std::uint64_t seed = 1) {
  sim::SwatchParams params;
  params.pattern = named_pattern(name);
  params.size = size;
  params.pixel_size_mm = px;
  params.seed = seed;
  return params;
}

}  // namespace psrig::test
