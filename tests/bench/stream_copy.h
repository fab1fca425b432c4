#pragma once
// BM_StreamCopy/12MP's scan and copy, the floor other 12 MP benchmarks are
// reported against (woodham_bench.cpp, process_bench.cpp): three 16-bit RGB
// frames of 4056x3040 read, and the solve's output bytes written, nothing
// computed.

#include <cstddef>
#include <vector>

#include "psrig/formats/scan.h"

namespace psrig::test {

// The 12 MP scan (a sphere under three lights), made once.
[[nodiscard]] const formats::Scan& stream_copy_scan();

// p, q, residual (float), albedo (3 floats), flags (1 byte) per pixel.
[[nodiscard]] std::size_t solve_output_bytes_per_pixel();

// One copy, on the pool: each row reads its input bytes once (three frame
// rows) and writes its output bytes once into `output` (sized here).
void stream_copy(const formats::Scan& scan, std::vector<unsigned char>& output);

}  // namespace psrig::test
