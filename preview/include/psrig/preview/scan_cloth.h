#pragma once
// What a scan tells the preview's cloth (`psrig-preview knit --from-scan`,
// the drapes): the fabric measured on its maps (report.json's `fabric`,
// else measured anew), and for a knit its stitch chart read off the maps
// (analysis/maps_fabric.h): which stitches are knit and which purl, the
// gauge and shear of the stitch lattice, each stitch's colour quantised to
// a palette.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "psrig/analysis/chart_inference.h"
#include "psrig/analysis/fabric_measure.h"
#include "psrig/base/error.h"
#include "psrig/formats/maps_reader.h"
#include "psrig/preview/cloth_model.h"

namespace psrig::preview {

struct ScanCloth {
  std::filesystem::path maps;
  analysis::FabricMeasurement fabric;
  // The chart read off the maps (gauge and palette included); nothing when
  // the scan is woven, has no repeat or does not look knitted (`why`).
  std::optional<analysis::InferredKnit> knit;
  std::string why;
  // The cloth's in-plane shear (x' = x + shear y, courses along x) and its
  // spacings at rest: of the stitch lattice when a chart was read, else of
  // the measured repeat's densities.
  float shear = 0;
  float wale_mm = 0, course_mm = 0;  // knits (0: not known)
  float end_mm = 0, pick_mm = 0;     // wovens (0: not known)
  Eigen::Vector3f mean_colour = Eigen::Vector3f::Zero();  // linear RGB, the albedo's mean
  std::vector<std::string> warnings;  // what the maps lack (maps_reader.h)

  // One linear RGB per stitch of a columns x rows cloth (row 0 first): the
  // read chart's colours tiled; empty without a chart.
  [[nodiscard]] std::vector<Eigen::Vector3f> stitch_colours(int columns, int rows) const;
  // The sizes to knit at: `given`'s where given (not 0), else the scan's
  // (for a knit, the yarn the chart read off it matched best with).
  [[nodiscard]] ClothSize cloth_size(ClothSize given, bool knit) const;
  // A few words: "chart 2 x 2 read off MAPS, 7.0 x 9.2 per cm, shear 0.10".
  [[nodiscard]] std::string describe() const;
};

// The cloth the maps show; `warnings`: what reading them found lacking.
[[nodiscard]] Result<ScanCloth> scan_cloth_of(const formats::Maps& maps,
                                              std::vector<std::string> warnings = {});
// Reads the maps directory, then as scan_cloth_of; read_maps's bad input
// naming it when it cannot be read.
[[nodiscard]] Result<ScanCloth> read_scan_cloth(const std::filesystem::path& maps);

}  // namespace psrig::preview
