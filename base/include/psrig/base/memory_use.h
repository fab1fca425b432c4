#pragma once
// The process's memory as Linux counts it (/proc/self), for reports: what
// processing held at most, stage by stage. Elsewhere every figure is 0.

#include <cstddef>

namespace psrig {

// Resident set size now, in bytes.
[[nodiscard]] std::size_t resident_bytes();

// The most resident at any moment (VmHWM) since the process started or since
// the last reset_peak_resident() that worked.
[[nodiscard]] std::size_t peak_resident_bytes();

// Starts the peak afresh from the resident size now (writing 5 to
// /proc/self/clear_refs, Linux 4.0 on); false where that is refused, and the
// peak stays the process's own.
bool reset_peak_resident();

}  // namespace psrig
