#pragma once
// What scan.json says about a simulated swatch's fabric: `fabric`, what a
// lab would enter (construction, structure, and how many wales and courses
// or ends and picks one repeat of its pattern holds), and
// `ground_truth.fabric`, the gauge it was made to, which `psrig measure` is
// tested against. psrig synth and the simulated rig write the same.

#include <nlohmann/json.hpp>

#include "psrig/sim/swatch_pattern.h"

namespace psrig::sim {

[[nodiscard]] nlohmann::json fabric_metadata(const SwatchPattern& pattern);

// `rotation_deg`: the fabric turned counterclockwise on the rig.
[[nodiscard]] nlohmann::json fabric_ground_truth(const SwatchPattern& pattern,
                                                 double rotation_deg);

}  // namespace psrig::sim
