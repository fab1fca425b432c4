#include "psrig/sim/fabric_truth.h"

namespace psrig::sim {

nlohmann::json fabric_metadata(const SwatchPattern& pattern) {
  const SwatchGauge& gauge = pattern.gauge;
  return {{"construction", gauge.knitted ? "knit" : "woven"},
          {"structure", pattern.name},
          {gauge.knitted ? "stitches_per_repeat" : "threads_per_repeat",
           {gauge.across_per_repeat, gauge.along_per_repeat}}};
}

nlohmann::json fabric_ground_truth(const SwatchPattern& pattern, double rotation_deg) {
  const SwatchGauge& gauge = pattern.gauge;
  nlohmann::json truth = fabric_metadata(pattern);
  truth[gauge.knitted ? "wales_per_cm" : "ends_per_cm"] = gauge.across_per_cm;
  truth[gauge.knitted ? "courses_per_cm" : "picks_per_cm"] = gauge.along_per_cm;
  truth["rotation_deg"] = rotation_deg;
  truth["skew_deg"] = 0.0;
  return truth;
}

}  // namespace psrig::sim
