#pragma once
// Measuring a fabric and reading its chart both work on the scan's central
// square of at most this many pixels a side, at full resolution: tens of
// repeats of any fabric the rig takes, and the finest weave's threads (15
// pixels apart) stay resolved, which shrinking a 12 MP scan would not keep.

namespace psrig::analysis {

inline constexpr int kMaxWorkingSide = 1280;

}  // namespace psrig::analysis
