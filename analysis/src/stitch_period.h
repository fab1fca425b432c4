#pragma once
// The repeat of a grid of stitches, for chart inference, found without
// knowing which stitch is which: a shift by a whole repeat maps every face
// onto one just like it, any other shift maps some onto different ones (a
// knit beside a purl, or a knit among purls beside one among knits). So
// the mean correlation of each face with the face a shift away, over the
// grid, peaks at the repeat's multiples (a stitch-level autocorrelation,
// as fabric_measure.h's is at the pixel level). Colour repeats are found
// alike from the stitches' palette entries.

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace psrig::analysis::inference {

struct Period {
  int columns = 1, rows = 1;
};

// `faces`: columns x rows, row-major, normalised (empty: not seen). Each
// direction's period is the shortest shift (at most max_period, and at
// most half the grid, so that two whole repeats are seen) whose mean
// correlation comes within a quarter of the spread from the best shift's.
[[nodiscard]] Period face_period(const std::vector<cv::Mat>& faces, int columns, int rows,
                                 int max_period);

// The same for palette entries: the shortest shift each way that keeps at
// least 95 % of the stitches' colours.
[[nodiscard]] Period colour_period(const std::vector<std::uint8_t>& colours, int columns, int rows,
                                   int max_period);

// The smallest period both repeat in (least common multiples).
[[nodiscard]] Period common_period(Period a, Period b);

}  // namespace psrig::analysis::inference
