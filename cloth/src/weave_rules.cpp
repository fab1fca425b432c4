#include "psrig/cloth/weave_rules.h"

namespace psrig::cloth {

namespace {

WeaveMatrix empty_weave(std::string name, int warps, int wefts) {
  WeaveMatrix weave;
  weave.name = std::move(name);
  weave.warps = warps;
  weave.wefts = wefts;
  weave.cells.assign(static_cast<std::size_t>(warps * wefts), 0);
  return weave;
}

void set_warp_over(WeaveMatrix& weave, int warp, int weft) {
  weave.cells[static_cast<std::size_t>(weft * weave.warps + warp)] = 1;
}

}  // namespace

WeaveMatrix plain_weave() {
  WeaveMatrix weave = empty_weave("plain weave", 2, 2);
  set_warp_over(weave, 0, 0);
  set_warp_over(weave, 1, 1);
  return weave;
}

WeaveMatrix twill_weave(int over, int under) {
  const int size = over + under;
  WeaveMatrix weave =
      empty_weave(std::to_string(over) + "/" + std::to_string(under) + " twill", size, size);
  // As twill-2x2.weave: row j has its warps j .. j + over - 1 up.
  for (int weft = 0; weft < size; ++weft)
    for (int k = 0; k < over; ++k)
      set_warp_over(weave, (weft + k) % size, weft);
  return weave;
}

WeaveMatrix satin_weave(int harnesses, int move, int picks_per_row) {
  std::string name = std::to_string(harnesses) + "-harness satin";
  if (picks_per_row > 1) name += ", picks x" + std::to_string(picks_per_row);
  WeaveMatrix weave = empty_weave(std::move(name), harnesses, harnesses * picks_per_row);
  for (int row = 0; row < harnesses; ++row)
    for (int pick = 0; pick < picks_per_row; ++pick)
      set_warp_over(weave, (row * move) % harnesses, row * picks_per_row + pick);
  return weave;
}

WeaveMatrix basket_weave(int n) {
  WeaveMatrix weave =
      empty_weave(std::to_string(n) + "/" + std::to_string(n) + " basket", 2 * n, 2 * n);
  for (int weft = 0; weft < 2 * n; ++weft)
    for (int warp = 0; warp < 2 * n; ++warp)
      if ((warp / n + weft / n) % 2 == 0) set_warp_over(weave, warp, weft);
  return weave;
}

std::vector<WeaveMatrix> chen2024_training_weaves() {
  return {plain_weave(),     twill_weave(2, 1), twill_weave(3, 2),   twill_weave(4, 4),
          satin_weave(5, 2), satin_weave(8, 3), satin_weave(5, 2, 2)};
}

}  // namespace psrig::cloth
