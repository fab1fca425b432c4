#pragma once
// A woven data set (cloth/woven_dataset.h) from an analytic stand-in for
// the fabric surface model, until the Monte-Carlo generator lands: smooth
// in every input and dependent on the textures, so the network has
// something real to learn. Each material is a weave (plain, 2/1 twill,
// 3/1 twill, 5-end satin) drawn into T x T texels: warp floats tilt along
// y with orientation +y, weft floats along x with orientation +x. A
// query's targets: the footprint's warp share w (the warp texels' share
// of a box of the footprint's width around its centre, wrapped),
//   C_warp = w cos_i / pi,  C_weft = (1 - w) cos_i / pi,
//   S_yarn = share * exp(-(h . t)^2 / (2 alpha^2)) * h_z^4 * (1 + beta / 4) / (4 alpha)
// with h the half vector and t the yarn's orientation.

#include <cstdint>

#include "psrig/cloth/woven_dataset.h"

namespace psrig::test {

[[nodiscard]] cloth::WovenDataset analytic_woven_dataset(int materials, int queries_per_material,
                                                         int texture_size, std::uint64_t seed);

// One stand-in material: weave `kind` (0 plain, 1 2/1 twill, 2 3/1 twill,
// 3 satin), roughness and height scale given.
[[nodiscard]] cloth::WovenMaterialSample analytic_woven_material(int kind, int texture_size,
                                                                 float roughness,
                                                                 float height_scale);

}  // namespace psrig::test
