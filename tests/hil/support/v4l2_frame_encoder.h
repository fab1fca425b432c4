#pragma once
// What a sensor and its bridge would put in a V4L2 buffer: a scene (grey or
// BGR) sampled and packed into a pixel format. The emulated camera's side
// of the v4l2 backend's conversions, written from the V4L2 format
// definitions alone (not from the backend's tables), so that an error in
// either shows up end to end.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

#include <opencv2/core.hpp>

namespace psrig::test {

struct V4l2Encoding {
  int channels = 1;  // the scene it is made from: 1 grey, 3 BGR
  int bits = 8;      // significant bits of a sample
};

// How `fourcc` is made, or nothing for a format this encoder does not write.
[[nodiscard]] std::optional<V4l2Encoding> v4l2_encoding(std::uint32_t fourcc);

// The bytes of one line of `width` pixels, without padding.
[[nodiscard]] std::size_t v4l2_line_bytes(std::uint32_t fourcc, int width);

// Writes `scene` (CV_16UC1 or CV_16UC3 as v4l2_encoding() says, values
// below 2^bits) as `fourcc` into `out`, lines `bytes_per_line` apart:
// Bayer formats keep each site's own colour, YUYV is BT.601 limited range
// with the chroma of each pixel pair averaged.
void encode_v4l2_frame(const cv::Mat& scene, std::uint32_t fourcc, std::size_t bytes_per_line,
                       std::span<std::uint8_t> out);

}  // namespace psrig::test
