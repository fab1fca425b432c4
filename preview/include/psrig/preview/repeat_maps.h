#pragma once
// The far level of draped cloth a chart feeds (issue 30): one repeat of the
// pattern as maps, as a scan gives them (swatch_maps.h), so that
// scan_surface.h draws them on the draped stitch mesh lit per pixel from
// the mesh's own normals, where the baked repeat (repeat_texture.h), lit
// and seen as its one repeat is, stands for flat cloth only.
//
// Made from the repeat baked at the near level (over black and over
// white) as the flat far level bakes it, under the frame's light:
// - albedo: the yarns' colour where they cover (the premultiplied colour
//   over the coverage; chen2003 5.2.2, eq. 11: colour weighted by density),
//   the repeat's coverage-weighted mean where nothing does, divided by the
//   shading a flat surface facing as the repeat did gets from that light:
//   drawn on that flat surface the maps are the bake again, so the switch
//   between flat and draped cloth does not pop;
// - alpha: the coverage, so the knit shows its gaps as the near level and
//   the flat far level do (a jersey, 2-9 % of the background), not a net;
// - normals: the cloth's plane (0, 0, 1). The bake's colour already holds
//   the yarns' own relief lit from that light (grooves, shadows, sheen);
//   normals of the yarns' surface would light it a second time, so the
//   mesh's normal alone carries the drape's shading and the Toksvig term
//   (Toksvig 2005) has nothing to widen (a flat map's mipmaps stay unit);
// - gloss 0: the yarns' sheen is in the bake, not added again.

#include <opencv2/core.hpp>

#include "psrig/preview/swatch_maps.h"

namespace psrig::preview {

struct RepeatMaps {
  SwatchMaps maps;
  // Albedo is stored within [0, 1] (an 8-bit texture): the light that
  // draws the maps is to be this much brighter (>= 1), where the flat
  // shading was dimmer than the bake's brightest colour (a lamp grazing
  // the repeat).
  float gain = 1;
};

// `texels`: the repeat's bake (repeat_texels: premultiplied linear colour
// and coverage, bottom row first); `flat_shading`: linear RGB a white
// flat surface facing as the repeat did gets from the bake's light
// (ambient included), as scan_surface.frag shades it; `repeat_mm`: the repeat's size at rest. The maps have square
// pixels (the bake resampled across the repeat's height), `pixel_size_mm` set.
[[nodiscard]] RepeatMaps repeat_maps(const cv::Mat& texels, const cv::Vec3f& flat_shading,
                                     const cv::Size2f& repeat_mm);

}  // namespace psrig::preview
