#include "stream_copy.h"

#include <algorithm>
#include <cstring>

#include "psrig/base/parallel.h"
#include "synthetic_scene.h"

namespace psrig::test {

const formats::Scan& stream_copy_scan() {
  static const formats::Scan scan = [] {
    const cv::Size size(4056, 3040);
    const auto surface = sphere_surface(size, size.height * 0.45, 3);
    return render_scan(surface, ring_lights(3, 45), CV_16U, 0.002);
  }();
  return scan;
}

std::size_t solve_output_bytes_per_pixel() {
  return 3 * sizeof(float) + 3 * sizeof(float) + 1;
}

void stream_copy(const formats::Scan& scan, std::vector<unsigned char>& output) {
  const cv::Size size = scan.size();
  const std::size_t out_row = static_cast<std::size_t>(size.width) * solve_output_bytes_per_pixel();
  const std::size_t in_row = scan.frames[0].cols * scan.frames[0].elemSize();
  output.resize(out_row * size.height);
  parallel_chunks(size.height, 8, [&](int begin, int end) {
    for (int r = begin; r < end; ++r) {
      unsigned char* out = output.data() + out_row * r;
      std::size_t written = 0;
      for (int k = 0; written < out_row; k = (k + 1) % 3) {
        const std::size_t n = std::min(in_row, out_row - written);
        std::memcpy(out + written, scan.frames[k].ptr(r), n);
        written += n;
      }
    }
  });
}

}  // namespace psrig::test
