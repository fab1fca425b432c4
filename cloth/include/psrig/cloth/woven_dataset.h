#pragma once
// The neural woven BSDF's training data (chen2024 5.1): materials, each a
// weave's ply normal and orientation textures over one repeat with its
// roughness and height scaling (what the network's encoder sees), and
// queries, each a footprint and a pair of directions (what its decoder
// sees), with the aggregated BSDF's four components (eq. 7) as targets.
// The file is `psrig-woven-dataset/1`: little-endian binary, laid out in
// docs of woven_dataset.cpp. The generator fills these from the fabric
// surface model; the trainer (tools/train-woven) reads them.

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "psrig/base/error.h"

namespace psrig::cloth {

// One material. The textures cover one repeat of the weave, T x T texels,
// row-major, texel (0, 0) at the repeat's (u, v) = (0, 0), u along the weft
// (x), v along the warp (y), three floats a texel. Gaps between yarns
// (where the ray meets no yarn) hold zero vectors in both.
struct WovenMaterialSample {
  std::string pattern;              // the weave's name ("2/2 twill", "3/1 twill", ...)
  int texture_size = 0;             // T
  std::vector<float> normal;        // T*T*3: the ply normal n_p, unit, +z out of the cloth's front
  std::vector<float> orientation;   // T*T*3: the ply orientation t_p, unit
  float roughness = 0;              // alpha (Table 1), both yarn types
  float height_scale = 0;           // beta (Table 1), both yarn types
  float twist_deg = 0;              // psi (Table 2), for the record
  float inclination_deg = 0;        // u (Table 2), for the record
};

// One query on a material and its answer. Directions are unit vectors in
// the cloth's frame (+z its front; x along the weft, y along the warp),
// both on the front (z > 0).
struct WovenQuery {
  std::uint32_t material = 0;       // index into WovenDataset::materials
  float u = 0, v = 0;               // footprint centre in repeats, [0, 1)
  float size = 0;                   // footprint width in repeats (0 to 5)
  std::array<float, 3> wi{}, wo{};  // incoming (towards the light) and outgoing (towards the eye)
  // The aggregated BSDF's components (eq. 7-8): f = kd_warp C_warp +
  // kd_weft C_weft + ks_warp S_warp + ks_weft S_weft.
  float c_warp = 0, c_weft = 0, s_warp = 0, s_weft = 0;
};

struct WovenDataset {
  std::vector<WovenMaterialSample> materials;
  std::vector<WovenQuery> queries;
  std::uint64_t seed = 0;           // what generated it, for the record
  std::string command;              // the command line that made it, for the record
};

// Written whole to `file` or not at all (a temporary renamed into place);
// read back with every size checked against the file's length, a bad file
// named with what is wrong.
[[nodiscard]] Status write_woven_dataset(const std::filesystem::path& file,
                                         const WovenDataset& dataset);
[[nodiscard]] Result<WovenDataset> read_woven_dataset(const std::filesystem::path& file);

}  // namespace psrig::cloth
