#include "v4l2_frame_encoder.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <linux/videodev2.h>
#include <stdexcept>
#include <vector>

namespace psrig::test {
namespace {

enum class Kind { grey8, grey16, yuyv, rgb24, bgr24, bayer8, bayer16, bayer10p, bayer12p };

struct Format {
  std::uint32_t fourcc;
  Kind kind;
  int bits;
  const char* mosaic;  // Bayer: the colours of the top-left 2x2, row by row
};

// From the V4L2 pixel format reference (Documentation/userspace-api/media/v4l).
constexpr std::array kFormats{
    Format{V4L2_PIX_FMT_GREY, Kind::grey8, 8, ""},
    Format{V4L2_PIX_FMT_Y10, Kind::grey16, 10, ""},
    Format{V4L2_PIX_FMT_Y12, Kind::grey16, 12, ""},
    Format{V4L2_PIX_FMT_Y16, Kind::grey16, 16, ""},
    Format{V4L2_PIX_FMT_YUYV, Kind::yuyv, 8, ""},
    Format{V4L2_PIX_FMT_RGB24, Kind::rgb24, 8, ""},
    Format{V4L2_PIX_FMT_BGR24, Kind::bgr24, 8, ""},
    Format{V4L2_PIX_FMT_SBGGR8, Kind::bayer8, 8, "BGGR"},
    Format{V4L2_PIX_FMT_SGBRG8, Kind::bayer8, 8, "GBRG"},
    Format{V4L2_PIX_FMT_SGRBG8, Kind::bayer8, 8, "GRBG"},
    Format{V4L2_PIX_FMT_SRGGB8, Kind::bayer8, 8, "RGGB"},
    Format{V4L2_PIX_FMT_SBGGR10, Kind::bayer16, 10, "BGGR"},
    Format{V4L2_PIX_FMT_SGBRG10, Kind::bayer16, 10, "GBRG"},
    Format{V4L2_PIX_FMT_SGRBG10, Kind::bayer16, 10, "GRBG"},
    Format{V4L2_PIX_FMT_SRGGB10, Kind::bayer16, 10, "RGGB"},
    Format{V4L2_PIX_FMT_SBGGR12, Kind::bayer16, 12, "BGGR"},
    Format{V4L2_PIX_FMT_SGBRG12, Kind::bayer16, 12, "GBRG"},
    Format{V4L2_PIX_FMT_SGRBG12, Kind::bayer16, 12, "GRBG"},
    Format{V4L2_PIX_FMT_SRGGB12, Kind::bayer16, 12, "RGGB"},
    Format{V4L2_PIX_FMT_SBGGR10P, Kind::bayer10p, 10, "BGGR"},
    Format{V4L2_PIX_FMT_SGBRG10P, Kind::bayer10p, 10, "GBRG"},
    Format{V4L2_PIX_FMT_SGRBG10P, Kind::bayer10p, 10, "GRBG"},
    Format{V4L2_PIX_FMT_SRGGB10P, Kind::bayer10p, 10, "RGGB"},
    Format{V4L2_PIX_FMT_SBGGR12P, Kind::bayer12p, 12, "BGGR"},
    Format{V4L2_PIX_FMT_SGBRG12P, Kind::bayer12p, 12, "GBRG"},
    Format{V4L2_PIX_FMT_SGRBG12P, Kind::bayer12p, 12, "GRBG"},
    Format{V4L2_PIX_FMT_SRGGB12P, Kind::bayer12p, 12, "RGGB"},
};

const Format* find(std::uint32_t fourcc) {
  for (const auto& f : kFormats)
    if (f.fourcc == fourcc) return &f;
  return nullptr;
}

bool is_bayer(Kind k) {
  return k == Kind::bayer8 || k == Kind::bayer16 || k == Kind::bayer10p || k == Kind::bayer12p;
}

// The sample a Bayer sensor records at (row, col): its site's colour only.
int bayer_sample(const cv::Mat& bgr, const char* mosaic, int row, int col) {
  const char c = mosaic[2 * (row % 2) + col % 2];
  const int channel = c == 'B' ? 0 : c == 'G' ? 1 : 2;
  return bgr.at<cv::Vec<std::uint16_t, 3>>(row, col)[channel];
}

std::uint8_t clamp8(double v) {
  return static_cast<std::uint8_t>(std::clamp(std::lround(v), 0L, 255L));
}

}  // namespace

std::optional<V4l2Encoding> v4l2_encoding(std::uint32_t fourcc) {
  const Format* f = find(fourcc);
  if (!f) return std::nullopt;
  const bool grey = f->kind == Kind::grey8 || f->kind == Kind::grey16;
  return V4l2Encoding{grey ? 1 : 3, f->bits};
}

std::size_t v4l2_line_bytes(std::uint32_t fourcc, int width) {
  const Format* f = find(fourcc);
  if (!f) throw std::invalid_argument("v4l2_line_bytes: unknown format");
  const auto w = static_cast<std::size_t>(width);
  switch (f->kind) {
    case Kind::grey8:
    case Kind::bayer8:
      return w;
    case Kind::grey16:
    case Kind::bayer16:
    case Kind::yuyv:
      return 2 * w;
    case Kind::rgb24:
    case Kind::bgr24:
      return 3 * w;
    case Kind::bayer10p:  // 4 pixels in 5 bytes
      return (w + 3) / 4 * 5;
    case Kind::bayer12p:  // 2 pixels in 3 bytes
      return (w + 1) / 2 * 3;
  }
  return w;
}

void encode_v4l2_frame(const cv::Mat& scene, std::uint32_t fourcc, std::size_t bytes_per_line,
                       std::span<std::uint8_t> out) {
  const Format* f = find(fourcc);
  const auto encoding = v4l2_encoding(fourcc);
  if (!f || scene.depth() != CV_16U || scene.channels() != encoding->channels)
    throw std::invalid_argument("encode_v4l2_frame: scene does not fit the format");
  const int width = scene.cols;
  const int height = scene.rows;
  if (out.size() < bytes_per_line * static_cast<std::size_t>(height) ||
      bytes_per_line < v4l2_line_bytes(fourcc, width))
    throw std::invalid_argument("encode_v4l2_frame: buffer too small");

  for (int y = 0; y < height; ++y) {
    std::uint8_t* line = out.data() + bytes_per_line * static_cast<std::size_t>(y);
    // Samples of this line as the sensor reads them out, one per pixel.
    std::vector<int> raw(static_cast<std::size_t>(width));
    if (is_bayer(f->kind) || f->kind == Kind::grey8 || f->kind == Kind::grey16)
      for (int x = 0; x < width; ++x)
        raw[x] = is_bayer(f->kind) ? bayer_sample(scene, f->mosaic, y, x)
                                   : scene.at<std::uint16_t>(y, x);
    switch (f->kind) {
      case Kind::grey8:
      case Kind::bayer8:
        for (int x = 0; x < width; ++x)
          line[x] = static_cast<std::uint8_t>(raw[x]);
        break;
      case Kind::grey16:
      case Kind::bayer16:  // little-endian, value in the low bits
        for (int x = 0; x < width; ++x) {
          line[2 * x] = static_cast<std::uint8_t>(raw[x] & 0xff);
          line[2 * x + 1] = static_cast<std::uint8_t>(raw[x] >> 8);
        }
        break;
      case Kind::bayer10p:  // MIPI RAW10: 4 high bytes, then the 4 low 2-bit pairs
        for (int x = 0; x < width; x += 4) {
          std::uint8_t* group = line + x / 4 * 5;
          group[4] = 0;
          for (int k = 0; k < 4; ++k) {
            const int v = x + k < width ? raw[x + k] : 0;
            group[k] = static_cast<std::uint8_t>(v >> 2);
            group[4] |= static_cast<std::uint8_t>((v & 0x3) << (2 * k));
          }
        }
        break;
      case Kind::bayer12p:  // MIPI RAW12: 2 high bytes, then both low nibbles
        for (int x = 0; x < width; x += 2) {
          std::uint8_t* group = line + x / 2 * 3;
          const int a = raw[x];
          const int b = x + 1 < width ? raw[x + 1] : 0;
          group[0] = static_cast<std::uint8_t>(a >> 4);
          group[1] = static_cast<std::uint8_t>(b >> 4);
          group[2] = static_cast<std::uint8_t>((a & 0xf) | ((b & 0xf) << 4));
        }
        break;
      case Kind::rgb24:
      case Kind::bgr24:
        for (int x = 0; x < width; ++x) {
          const auto& p = scene.at<cv::Vec<std::uint16_t, 3>>(y, x);
          const bool rgb = f->kind == Kind::rgb24;
          line[3 * x + 0] = static_cast<std::uint8_t>(rgb ? p[2] : p[0]);
          line[3 * x + 1] = static_cast<std::uint8_t>(p[1]);
          line[3 * x + 2] = static_cast<std::uint8_t>(rgb ? p[0] : p[2]);
        }
        break;
      case Kind::yuyv:  // Y0 U Y1 V per pixel pair
        for (int x = 0; x + 1 < width; x += 2) {
          double u = 0, v = 0;
          for (int k = 0; k < 2; ++k) {
            const auto& p = scene.at<cv::Vec<std::uint16_t, 3>>(y, x + k);
            const double b = p[0], g = p[1], r = p[2];
            line[2 * (x + k)] = clamp8(16 + (65.481 * r + 128.553 * g + 24.966 * b) / 255);
            u += (-37.797 * r - 74.203 * g + 112.0 * b) / 255 / 2;
            v += (112.0 * r - 93.786 * g - 18.214 * b) / 255 / 2;
          }
          line[2 * x + 1] = clamp8(128 + u);
          line[2 * x + 3] = clamp8(128 + v);
        }
        break;
    }
  }
}

}  // namespace psrig::test
