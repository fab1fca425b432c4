#pragma once
// The neural woven BSDF's picture (chen2024 6): the same swatch, camera and
// light as woven_reference_render.h, each pixel one decoder query
// (woven_network.h) for that pixel's footprint (WovenCamera::pixel_footprint)
// and directions, the four components combined by eq. (8) with the yarns'
// k_d and k_s, times the light's irradiance, as the reference does. No
// samples and no noise: what the network learnt of eq. (3) over the
// footprint, at the cost of one query a pixel.
//
// The decoder takes a square footprint (the data set's): a pixel's
// parallelogram becomes the square of the same area, in repeats.

#include <Eigen/Core>

#include "psrig/cloth/woven_network.h"
#include "psrig/cloth/woven_reference_render.h"

namespace psrig::cloth {

// What a pixel's footprint asks the decoder: centre (u, v) in repeats,
// wrapped to [0, 1), and the width of the square of the same area in
// repeats; wi and wo are the caller's.
[[nodiscard]] WovenLookup footprint_lookup(const Footprint& footprint,
                                           const Eigen::Vector2f& repeat_size);

// `material` is the network's prepared latent of the swatch's material
// (encode, then prepare); `repeat_size` its repeat in yarn spacings
// (WovenSurface::repeat_size). Runs on the thread pool, a row a task.
[[nodiscard]] WovenImage render_woven_neural(const WovenNetwork& network,
                                             const WovenDecoderMaterial& material,
                                             const Eigen::Vector2f& repeat_size,
                                             const YarnColours& colours, const WovenView& view,
                                             const WovenLight& light, int width, int height);
// The same through a camera placed by the caller.
[[nodiscard]] WovenImage render_woven_neural(const WovenNetwork& network,
                                             const WovenDecoderMaterial& material,
                                             const Eigen::Vector2f& repeat_size,
                                             const YarnColours& colours, const WovenCamera& camera,
                                             const WovenLight& light);

}  // namespace psrig::cloth
