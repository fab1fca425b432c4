#include "psrig/cameras/v4l2_formats.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cstring>
#include <linux/videodev2.h>

#include <opencv2/imgproc.hpp>

namespace psrig::cameras {
namespace {

using L = V4l2Layout;
using B = BayerOrder;

// Best for photometry first (see photometric_rank).
constexpr std::array kFormats{
    V4l2PixelFormat{V4L2_PIX_FMT_Y16, "Y16", L::grey16, B::none, 16, false, true, 100},
    V4l2PixelFormat{V4L2_PIX_FMT_Y16_BE, "Y16_BE", L::grey16_be, B::none, 16, false, true, 99},
    V4l2PixelFormat{V4L2_PIX_FMT_Y12, "Y12", L::grey16, B::none, 12, false, true, 96},
    V4l2PixelFormat{V4L2_PIX_FMT_Y10, "Y10", L::grey16, B::none, 10, false, true, 94},
    V4l2PixelFormat{V4L2_PIX_FMT_Y10P, "Y10P", L::grey10p, B::none, 10, false, true, 93},
    V4l2PixelFormat{V4L2_PIX_FMT_SBGGR16, "SBGGR16", L::bayer16, B::bggr, 16, true, true, 90},
    V4l2PixelFormat{V4L2_PIX_FMT_SGBRG16, "SGBRG16", L::bayer16, B::gbrg, 16, true, true, 90},
    V4l2PixelFormat{V4L2_PIX_FMT_SGRBG16, "SGRBG16", L::bayer16, B::grbg, 16, true, true, 90},
    V4l2PixelFormat{V4L2_PIX_FMT_SRGGB16, "SRGGB16", L::bayer16, B::rggb, 16, true, true, 90},
    V4l2PixelFormat{V4L2_PIX_FMT_SBGGR12, "SBGGR12", L::bayer16, B::bggr, 12, true, true, 88},
    V4l2PixelFormat{V4L2_PIX_FMT_SGBRG12, "SGBRG12", L::bayer16, B::gbrg, 12, true, true, 88},
    V4l2PixelFormat{V4L2_PIX_FMT_SGRBG12, "SGRBG12", L::bayer16, B::grbg, 12, true, true, 88},
    V4l2PixelFormat{V4L2_PIX_FMT_SRGGB12, "SRGGB12", L::bayer16, B::rggb, 12, true, true, 88},
    V4l2PixelFormat{V4L2_PIX_FMT_SBGGR12P, "SBGGR12P", L::bayer12p, B::bggr, 12, true, true, 87},
    V4l2PixelFormat{V4L2_PIX_FMT_SGBRG12P, "SGBRG12P", L::bayer12p, B::gbrg, 12, true, true, 87},
    V4l2PixelFormat{V4L2_PIX_FMT_SGRBG12P, "SGRBG12P", L::bayer12p, B::grbg, 12, true, true, 87},
    V4l2PixelFormat{V4L2_PIX_FMT_SRGGB12P, "SRGGB12P", L::bayer12p, B::rggb, 12, true, true, 87},
    V4l2PixelFormat{V4L2_PIX_FMT_SBGGR10, "SBGGR10", L::bayer16, B::bggr, 10, true, true, 85},
    V4l2PixelFormat{V4L2_PIX_FMT_SGBRG10, "SGBRG10", L::bayer16, B::gbrg, 10, true, true, 85},
    V4l2PixelFormat{V4L2_PIX_FMT_SGRBG10, "SGRBG10", L::bayer16, B::grbg, 10, true, true, 85},
    V4l2PixelFormat{V4L2_PIX_FMT_SRGGB10, "SRGGB10", L::bayer16, B::rggb, 10, true, true, 85},
    V4l2PixelFormat{V4L2_PIX_FMT_SBGGR10P, "SBGGR10P", L::bayer10p, B::bggr, 10, true, true, 84},
    V4l2PixelFormat{V4L2_PIX_FMT_SGBRG10P, "SGBRG10P", L::bayer10p, B::gbrg, 10, true, true, 84},
    V4l2PixelFormat{V4L2_PIX_FMT_SGRBG10P, "SGRBG10P", L::bayer10p, B::grbg, 10, true, true, 84},
    V4l2PixelFormat{V4L2_PIX_FMT_SRGGB10P, "SRGGB10P", L::bayer10p, B::rggb, 10, true, true, 84},
    V4l2PixelFormat{V4L2_PIX_FMT_SBGGR8, "SBGGR8", L::bayer8, B::bggr, 8, true, true, 80},
    V4l2PixelFormat{V4L2_PIX_FMT_SGBRG8, "SGBRG8", L::bayer8, B::gbrg, 8, true, true, 80},
    V4l2PixelFormat{V4L2_PIX_FMT_SGRBG8, "SGRBG8", L::bayer8, B::grbg, 8, true, true, 80},
    V4l2PixelFormat{V4L2_PIX_FMT_SRGGB8, "SRGGB8", L::bayer8, B::rggb, 8, true, true, 80},
    V4l2PixelFormat{V4L2_PIX_FMT_GREY, "GREY", L::grey8, B::none, 8, false, true, 70},
    V4l2PixelFormat{V4L2_PIX_FMT_BGR24, "BGR24", L::bgr24, B::none, 8, true, false, 60},
    V4l2PixelFormat{V4L2_PIX_FMT_RGB24, "RGB24", L::rgb24, B::none, 8, true, false, 59},
    V4l2PixelFormat{V4L2_PIX_FMT_YUYV, "YUYV", L::yuyv, B::none, 8, true, false, 50},
};

// OpenCV names a Bayer pattern by the second row's second and third
// pixels, V4L2 by the first row's first two: OpenCV's "BG" is V4L2's RGGB.
int demosaic_code(BayerOrder order) {
  switch (order) {
    case BayerOrder::rggb:
      return cv::COLOR_BayerBG2BGR;
    case BayerOrder::bggr:
      return cv::COLOR_BayerRG2BGR;
    case BayerOrder::gbrg:
      return cv::COLOR_BayerGR2BGR;
    case BayerOrder::grbg:
      return cv::COLOR_BayerGB2BGR;
    case BayerOrder::none:
      break;
  }
  return -1;
}

std::uint16_t load_le16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
std::uint16_t load_be16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>((p[0] << 8) | p[1]);
}

// 16-bit samples, one line at a time: a memcpy on little-endian hosts.
cv::Mat unpack16(const std::uint8_t* data, int width, int height, std::size_t stride,
                 bool big_endian) {
  cv::Mat out(height, width, CV_16UC1);
  for (int r = 0; r < height; ++r) {
    const std::uint8_t* line = data + r * stride;
    auto* dst = out.ptr<std::uint16_t>(r);
    if (!big_endian && std::endian::native == std::endian::little) {
      std::memcpy(dst, line, static_cast<std::size_t>(width) * 2);
    } else {
      for (int c = 0; c < width; ++c)
        dst[c] = big_endian ? load_be16(line + 2 * c) : load_le16(line + 2 * c);
    }
  }
  return out;
}

// MIPI CSI-2 RAW10: four pixels' high 8 bits, then one byte of their low
// 2 bits (pixel 0 in bits 1:0, pixel 3 in bits 7:6).
cv::Mat unpack10p(const std::uint8_t* data, int width, int height, std::size_t stride) {
  cv::Mat out(height, width, CV_16UC1);
  for (int r = 0; r < height; ++r) {
    const std::uint8_t* group = data + r * stride;
    auto* dst = out.ptr<std::uint16_t>(r);
    for (int c = 0; c < width; c += 4, group += 5)
      for (int k = 0; k < 4 && c + k < width; ++k)
        dst[c + k] = static_cast<std::uint16_t>((group[k] << 2) | ((group[4] >> (2 * k)) & 0x3));
  }
  return out;
}

// MIPI CSI-2 RAW12: two pixels' high 8 bits, then one byte of their low
// 4 bits (pixel 0 in bits 3:0, pixel 1 in bits 7:4).
cv::Mat unpack12p(const std::uint8_t* data, int width, int height, std::size_t stride) {
  cv::Mat out(height, width, CV_16UC1);
  for (int r = 0; r < height; ++r) {
    const std::uint8_t* group = data + r * stride;
    auto* dst = out.ptr<std::uint16_t>(r);
    for (int c = 0; c < width; c += 2, group += 3) {
      dst[c] = static_cast<std::uint16_t>((group[0] << 4) | (group[2] & 0x0f));
      if (c + 1 < width) dst[c + 1] = static_cast<std::uint16_t>((group[1] << 4) | (group[2] >> 4));
    }
  }
  return out;
}

cv::Mat demosaic(const cv::Mat& mosaic, BayerOrder order) {
  cv::Mat bgr;
  cv::cvtColor(mosaic, bgr, demosaic_code(order));
  return bgr;
}

}  // namespace

std::span<const V4l2PixelFormat> v4l2_pixel_formats() {
  return kFormats;
}

std::optional<V4l2PixelFormat> find_v4l2_format(std::uint32_t fourcc) {
  for (const auto& f : kFormats)
    if (f.fourcc == fourcc) return f;
  return std::nullopt;
}

std::optional<V4l2PixelFormat> find_v4l2_format(std::string_view text) {
  // Fourccs are case-sensitive (pgAA is GRBG, pGAA is GBRG): exact first.
  if (!text.empty() && text.size() <= 4) {
    std::array<char, 4> c{' ', ' ', ' ', ' '};
    std::copy(text.begin(), text.end(), c.begin());
    const auto code = v4l2_fourcc(c[0], c[1], c[2], c[3]);
    if (auto f = find_v4l2_format(code)) return f;
  }
  const auto same = [](std::string_view a, std::string_view b) {
    return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
             return std::toupper(static_cast<unsigned char>(x)) ==
                    std::toupper(static_cast<unsigned char>(y));
           });
  };
  for (const auto& f : kFormats)
    if (same(f.name, text)) return f;
  return std::nullopt;
}

std::string fourcc_to_string(std::uint32_t fourcc) {
  std::string s;
  for (int i = 0; i < 4; ++i) {
    const auto c = static_cast<char>((fourcc >> (8 * i)) & 0x7f);
    s += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
  }
  while (!s.empty() && s.back() == ' ')
    s.pop_back();
  if (fourcc & (1u << 31)) s += "-BE";
  return s;
}

std::size_t v4l2_min_bytes_per_line(const V4l2PixelFormat& format, int width) {
  const auto w = static_cast<std::size_t>(std::max(width, 0));
  switch (format.layout) {
    case L::grey8:
    case L::bayer8:
      return w;
    case L::grey16:
    case L::grey16_be:
    case L::bayer16:
    case L::yuyv:
      return 2 * w;
    case L::rgb24:
    case L::bgr24:
      return 3 * w;
    case L::grey10p:
    case L::bayer10p:
      return (w + 3) / 4 * 5;
    case L::bayer12p:
      return (w + 1) / 2 * 3;
  }
  return w;
}

Result<cv::Mat> convert_v4l2_frame(std::span<const std::uint8_t> data,
                                   const V4l2PixelFormat& format, int width, int height,
                                   std::size_t bytes_per_line) {
  const std::string what =
      fourcc_to_string(format.fourcc) + " " + std::to_string(width) + "x" + std::to_string(height);
  if (width <= 0 || height <= 0)
    return std::unexpected(internal_error("v4l2 frame " + what + ": empty size"));
  const std::size_t min_line = v4l2_min_bytes_per_line(format, width);
  if (bytes_per_line < min_line)
    return std::unexpected(internal_error("v4l2 frame " + what + ": " +
                                          std::to_string(bytes_per_line) +
                                          " bytes per line, need " + std::to_string(min_line)));
  const std::size_t needed = bytes_per_line * static_cast<std::size_t>(height - 1) + min_line;
  if (data.size() < needed)
    return std::unexpected(io_error(
        {}, "v4l2 frame " + what + " is short: " + std::to_string(data.size()) + " bytes, need " +
                std::to_string(needed) + " (a truncated transfer: check the cable or bandwidth)"));
  if (format.layout == L::yuyv && width % 2 != 0)
    return std::unexpected(internal_error("v4l2 frame " + what + ": odd YUYV width"));

  // OpenCV does not write through a Mat header over const memory; we only read.
  auto* bytes = const_cast<std::uint8_t*>(data.data());
  const auto view = [&](int type) { return cv::Mat(height, width, type, bytes, bytes_per_line); };
  cv::Mat out;
  try {
    switch (format.layout) {
      case L::grey8:
        out = view(CV_8UC1).clone();
        break;
      case L::grey16:
        out = unpack16(bytes, width, height, bytes_per_line, false);
        break;
      case L::grey16_be:
        out = unpack16(bytes, width, height, bytes_per_line, true);
        break;
      case L::grey10p:
        out = unpack10p(bytes, width, height, bytes_per_line);
        break;
      case L::yuyv:
        cv::cvtColor(view(CV_8UC2), out, cv::COLOR_YUV2BGR_YUYV);
        break;
      case L::rgb24:
        cv::cvtColor(view(CV_8UC3), out, cv::COLOR_RGB2BGR);
        break;
      case L::bgr24:
        out = view(CV_8UC3).clone();
        break;
      case L::bayer8:
        out = demosaic(view(CV_8UC1), format.bayer);
        break;
      case L::bayer16:
        out = demosaic(unpack16(bytes, width, height, bytes_per_line, false), format.bayer);
        break;
      case L::bayer10p:
        out = demosaic(unpack10p(bytes, width, height, bytes_per_line), format.bayer);
        break;
      case L::bayer12p:
        out = demosaic(unpack12p(bytes, width, height, bytes_per_line), format.bayer);
        break;
    }
  } catch (const cv::Exception& e) {  // e.g. a mosaic too small to demosaic
    return std::unexpected(internal_error("v4l2 frame " + what + ": " + e.what()));
  }
  return out;
}

}  // namespace psrig::cameras
