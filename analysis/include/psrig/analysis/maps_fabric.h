#pragma once
// The fabric and the knit's chart of a maps directory read back
// (formats/maps_reader.h): the measurement and the inference fed as every
// caller feeds them, from the maps' height (else their p gradient), albedo
// and pixel size and the scan's word on its fabric (scan.json's `fabric`).

#include <string>
#include <vector>

#include "psrig/analysis/chart_inference.h"
#include "psrig/analysis/fabric_measure.h"
#include "psrig/base/error.h"
#include "psrig/formats/maps_reader.h"

namespace psrig::analysis {

// The fabric measured on the maps now (psrig measure: the explicit step).
[[nodiscard]] Result<FabricMeasurement> measure_maps(const formats::Maps& maps);

// report.json's `fabric` when it has a usable one, else measured now
// (measure_maps); an unusable one is said in `warnings`.
[[nodiscard]] Result<FabricMeasurement> fabric_of_maps(const formats::Maps& maps,
                                                       std::vector<std::string>& warnings);

// The knit's chart read off the maps, `fabric` their measurement, the
// stitches the scan counts in a repeat taken as given (options_from_scan).
[[nodiscard]] Result<InferredKnit> infer_knit_chart(const formats::Maps& maps,
                                                    const FabricMeasurement& fabric);

}  // namespace psrig::analysis
