#pragma once
// Knitted maps (knitted_maps.h) as a scan directory: normals from the
// height, Lambertian frames under the default rig's three lights (slant
// 45 degrees, tilts 0, 120 and 240), 16-bit with the simulated sensor's
// noise, scan.json saying the pixel size and that the fabric is knitted.
// What `psrig synth --pattern CHART` is to give, until it does.

#include <filesystem>
#include <string>

#include "knitted_maps.h"
#include "psrig/base/error.h"

namespace psrig::test {

[[nodiscard]] Status write_knitted_scan(const KnittedMaps& maps, const std::string& structure,
                                        const std::filesystem::path& directory);

}  // namespace psrig::test
