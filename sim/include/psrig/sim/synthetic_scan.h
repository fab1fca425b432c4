#pragma once
// A synthetic scan: the simulated world's swatch rendered under the rig's
// three lights, with its ground truth. What `psrig synth` writes.

#include <cstdint>

#include "psrig/formats/scan.h"
#include "psrig/sim/swatch_model.h"

namespace psrig::sim {

struct SyntheticScanParams {
  SwatchParams swatch;
  double slant_deg = 45;  // all three lights; tilts 0, 120, 240
  double noise = 0;       // Gaussian, standard deviation as a fraction of full scale
  int depth = CV_16U;     // CV_8U or CV_16U
  double exposure = 1.0;  // scales the radiance before quantisation
  bool cast_shadows = true;
  // scan.json's `fabric` (construction, structure, stitches or threads per
  // repeat) as a lab would enter it (fabric_truth.h); off, the measurement
  // has to tell knit from woven by itself.
  bool fabric_metadata = true;
};

// Frames, light directions and ground truth (normals, height in mm), ready
// for formats::write_scan or processing::solve. Deterministic for a seed.
// Bad input when the swatch's pattern makes no cloth (sim::make_swatch).
[[nodiscard]] Result<formats::Scan> make_synthetic_scan(const SyntheticScanParams& params);

}  // namespace psrig::sim
