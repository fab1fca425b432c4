#pragma once
// V4L2 pixel formats psrig can take frames in, and their conversion from a
// driver's buffer to a cv::Mat (CV_8U or CV_16U, grey or BGR). Pure
// functions: no device needed, so every conversion is unit-tested.
//
// Photometric stereo wants intensities proportional to the light. Raw
// sensor data (Y10/Y12/Y16, Bayer RAW, GREY from a monochrome sensor) is
// linear. RGB24/BGR24 and YUYV come out of an ISP or a UVC webcam already
// gamma-encoded (and often with auto white balance and tone curves that no
// decoding undoes): such a camera is a weak choice for the rig, and a scan
// from it must record `encoding = "srgb"` so that processing decodes it.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"

namespace psrig::cameras {

// How a format lays its samples out in memory.
enum class V4l2Layout {
  grey8,      // GREY
  grey16,     // Y10, Y12, Y16: little-endian 16-bit containers, value in the low bits
  grey16_be,  // Y16_BE
  grey10p,    // Y10P: MIPI CSI-2 packed, 4 pixels in 5 bytes
  yuyv,       // YUYV 4:2:2
  rgb24,      // RGB3
  bgr24,      // BGR3
  bayer8,     // BA81, GBRG, GRBG, RGGB
  bayer16,    // BG10, GB10, BA10, RG10, BG12, ... BYR2: 16-bit containers, value in the low bits
  bayer10p,   // pBAA, pGAA, pgAA, pRAA: MIPI packed, 4 pixels in 5 bytes
  bayer12p,   // pBCC, pGCC, pgCC, pRCC: MIPI packed, 2 pixels in 3 bytes
};

// The colour of the top-left 2x2 of a Bayer mosaic, row by row, as V4L2 names it.
enum class BayerOrder { none, bggr, gbrg, grbg, rggb };

struct V4l2PixelFormat {
  std::uint32_t fourcc = 0;
  std::string_view name;  // V4L2's name without the V4L2_PIX_FMT_ prefix, e.g. "SBGGR10P"
  V4l2Layout layout = V4l2Layout::grey8;
  BayerOrder bayer = BayerOrder::none;
  int bits = 8;         // significant bits per sample
  bool colour = false;  // frames come out BGR (else grey)
  bool linear = true;   // sensor data, proportional to light (else gamma-encoded: sRGB-like)
  // Preference when camera.format = "auto": higher is better for photometry
  // (linear before encoded, more bits before fewer).
  int photometric_rank = 0;

  // Full scale of the converted frame: 2^bits - 1 in its 8- or 16-bit container.
  [[nodiscard]] double white_level() const { return static_cast<double>((1u << bits) - 1); }
  // "linear" or "srgb", as a scan's `encoding` records it.
  [[nodiscard]] std::string_view encoding() const { return linear ? "linear" : "srgb"; }
};

// Every format psrig converts, best for photometry first.
[[nodiscard]] std::span<const V4l2PixelFormat> v4l2_pixel_formats();
[[nodiscard]] std::optional<V4l2PixelFormat> find_v4l2_format(std::uint32_t fourcc);
// A fourcc as in camera.format: the four characters exactly ("Y16", "pBAA";
// trailing blanks may be left out) or V4L2's name ("SBGGR10P", "RGB24").
[[nodiscard]] std::optional<V4l2PixelFormat> find_v4l2_format(std::string_view text);

// "YUYV", "Y16", "pBAA": the four characters, trailing blanks dropped,
// unprintable ones as '?'; big-endian variants end in "-BE".
[[nodiscard]] std::string fourcc_to_string(std::uint32_t fourcc);

// The fewest bytes a line of `width` pixels takes.
[[nodiscard]] std::size_t v4l2_min_bytes_per_line(const V4l2PixelFormat& format, int width);

// The frame in `data` (a driver's buffer: `height` lines `bytes_per_line`
// apart) as a cv::Mat: CV_8U for 8-bit formats, else CV_16U with the value
// in the low bits; BGR for colour and Bayer formats (demosaiced,
// bilinear: a linear filter, so linear data stays linear), else grey.
[[nodiscard]] Result<cv::Mat> convert_v4l2_frame(std::span<const std::uint8_t> data,
                                                 const V4l2PixelFormat& format, int width,
                                                 int height, std::size_t bytes_per_line);

}  // namespace psrig::cameras
