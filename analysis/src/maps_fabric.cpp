#include "psrig/analysis/maps_fabric.h"

namespace psrig::analysis {
namespace {

// The relief the lattice is found on: maps processed without integration
// have no height, and the p gradient repeats as the height would.
const cv::Mat& relief_of(const formats::Maps& maps) {
  return maps.height.empty() ? maps.p : maps.height;
}

}  // namespace

Result<FabricMeasurement> measure_maps(const formats::Maps& maps) {
  MeasureOptions options;
  options.pixel_size_mm = maps.pixel_size_mm;
  options.hints = fabric_hints(maps.scan_document);
  return measure_fabric(relief_of(maps), maps.albedo, options);
}

Result<FabricMeasurement> fabric_of_maps(const formats::Maps& maps,
                                         std::vector<std::string>& warnings) {
  if (maps.report.is_object() && maps.report.contains("fabric")) {
    auto fabric = fabric_from_json(maps.report["fabric"], maps.pixel_size_mm);
    if (fabric) return fabric;
    warnings.push_back(fabric.error().describe() + "; measuring the maps instead");
  }
  return measure_maps(maps);
}

Result<InferredKnit> infer_knit_chart(const formats::Maps& maps, const FabricMeasurement& fabric) {
  return infer_knit_chart(relief_of(maps), maps.albedo, fabric,
                          options_from_scan(fabric, fabric_hints(maps.scan_document)));
}

}  // namespace psrig::analysis
