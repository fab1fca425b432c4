#pragma once
// Weaves made from the weaver's rules rather than read from a .weave file:
// the families chen2024 (5.1) trains on (plain, twill 3x3, 5x5, 8x8, satin
// 5x5, 8x8, 5x10) and the patterns it never saw (a 3/1 twill, a 2/2
// basket). Same convention as weave_matrix.h: row j is weft j, column i
// warp i, 1 where the warp lies over the weft.

#include <string>
#include <vector>

#include "psrig/cloth/weave_matrix.h"

namespace psrig::cloth {

// Plain weave (tabby), 2 x 2: a checkerboard.
[[nodiscard]] WeaveMatrix plain_weave();

// An `over`/`under` twill: each weft passes under `over` warps and over
// `under` (the warp floats over `over` wefts), the pattern moving one warp on
// each weft, so the floats line up in a diagonal; (over + under) square.
[[nodiscard]] WeaveMatrix twill_weave(int over, int under);

// A regular satin of `harnesses` with move number `move` (coprime with it,
// and neither 1 nor harnesses - 1, or it is a twill): on weft j the one warp
// (j * move) mod harnesses lies over it. Weft-faced, like satin-5.weave.
// `picks_per_row` repeats each weft that many times (2 gives chen2024's
// elongated "satin 5x10": 5 warps by 10 wefts; our reading of the name).
[[nodiscard]] WeaveMatrix satin_weave(int harnesses, int move, int picks_per_row = 1);

// An n/n basket (hopsack): plain weave with every warp and weft doubled
// (n = 2) or more, 2n x 2n.
[[nodiscard]] WeaveMatrix basket_weave(int n);

// chen2024's seven training patterns in its order: plain, twill 3x3 (2/1),
// twill 5x5 (3/2), twill 8x8 (4/4), satin 5x5 (move 2), satin 8x8 (move 3),
// satin 5x10 (satin 5 with each pick doubled). The paper gives only the
// sizes; the float lengths are our choice, the most balanced of each size.
[[nodiscard]] std::vector<WeaveMatrix> chen2024_training_weaves();

}  // namespace psrig::cloth
