#include "psrig/formats/map_encoding.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "psrig/base/parallel.h"
#include "psrig/base/vector_clones.h"

namespace psrig::formats {
namespace {

constexpr int kRowsPerChunk = 16;
// Table resolution: in sRGB's linear toe one step moves the 8-bit code by
// 0.05, so the table agrees with the exact encoding.
constexpr int kSrgbSteps = 65536;

const std::vector<std::uint8_t>& srgb_table() {
  static const auto table = [] {
    std::vector<std::uint8_t> t(kSrgbSteps + 1);
    for (int i = 0; i <= kSrgbSteps; ++i) {
      const double linear = static_cast<double>(i) / kSrgbSteps;
      const double encoded =
          linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1 / 2.4) - 0.055;
      t[i] = static_cast<std::uint8_t>(std::lround(encoded * 255));
    }
    return t;
  }();
  return table;
}

PSRIG_VECTOR_CLONES
void normal_row(const float* __restrict p, const float* __restrict q, std::uint16_t* __restrict bgr,
                int n) {
  for (int i = 0; i < n; ++i) {
    const float inverse = 1.0f / std::sqrt(p[i] * p[i] + q[i] * q[i] + 1.0f);
    // (n + 1) / 2 * 65535, rounded; n = (-p, -q, 1) / |(-p, -q, 1)|
    bgr[3 * i] = static_cast<std::uint16_t>((inverse + 1.0f) * 32767.5f + 0.5f);
    bgr[3 * i + 1] = static_cast<std::uint16_t>((1.0f - q[i] * inverse) * 32767.5f + 0.5f);
    bgr[3 * i + 2] = static_cast<std::uint16_t>((1.0f - p[i] * inverse) * 32767.5f + 0.5f);
  }
}

}  // namespace

cv::Mat encode_albedo_srgb8(const cv::Mat& albedo) {
  cv::Mat out(albedo.size(), CV_8UC(albedo.channels()));
  const auto& table = srgb_table();
  const int values = albedo.cols * albedo.channels();
  parallel_chunks(albedo.rows, kRowsPerChunk, [&](int begin, int end) {
    for (int r = begin; r < end; ++r) {
      const float* in = albedo.ptr<float>(r);
      std::uint8_t* o = out.ptr<std::uint8_t>(r);
      for (int i = 0; i < values; ++i) {
        // NaN and negatives to 0, above 1 to 1 (a NaN comparison is false).
        const float clamped = in[i] > 0.0f ? std::min(in[i], 1.0f) : 0.0f;
        o[i] = table[static_cast<int>(clamped * kSrgbSteps + 0.5f)];
      }
    }
  });
  return out;
}

cv::Mat encode_normal16(const cv::Mat& p, const cv::Mat& q) {
  cv::Mat out(p.size(), CV_16UC3);
  parallel_chunks(p.rows, kRowsPerChunk, [&](int begin, int end) {
    for (int r = begin; r < end; ++r)
      normal_row(p.ptr<float>(r), q.ptr<float>(r), out.ptr<std::uint16_t>(r), p.cols);
  });
  return out;
}

cv::Mat flip_normal_green(const cv::Mat& normal) {
  cv::Mat out = normal.clone();
  const double full = normal.depth() == CV_16U ? 65535.0 : 255.0;
  cv::Mat green;
  cv::extractChannel(normal, green, 1);  // BGR: 1 is green
  green.convertTo(green, green.type(), -1.0, full);
  cv::insertChannel(green, out, 1);
  return out;
}

DecodedGradients decode_normal_map(const cv::Mat& image, bool green_down) {
  const int depth = image.depth();
  const int channels = image.channels();
  if (image.empty() || (channels != 3 && channels != 4) ||
      (depth != CV_8U && depth != CV_16U && depth != CV_32F))
    return {};
  cv::Mat values;
  if (depth == CV_32F)
    values = image;
  else
    image.convertTo(values, CV_32F, 2.0 / (depth == CV_8U ? 255.0 : 65535.0), -1.0);
  DecodedGradients out{cv::Mat(image.size(), CV_32F), cv::Mat(image.size(), CV_32F)};
  const float nan = std::numeric_limits<float>::quiet_NaN();
  parallel_chunks(image.rows, kRowsPerChunk, [&](int begin, int end) {
    for (int r = begin; r < end; ++r) {
      const float* v = values.ptr<float>(r);
      const auto* alpha8 = image.ptr<std::uint8_t>(r);
      const auto* alpha16 = image.ptr<std::uint16_t>(r);
      const float* alpha32 = image.ptr<float>(r);
      float* p = out.p.ptr<float>(r);
      float* q = out.q.ptr<float>(r);
      for (int c = 0; c < image.cols; ++c) {
        const float* px = v + static_cast<std::ptrdiff_t>(c) * channels;  // B, G, R(, A)
        const float nx = px[2];
        const float ny = green_down ? -px[1] : px[1];
        const float nz = px[0];
        bool ok = std::isfinite(nx) && std::isfinite(ny) && std::isfinite(nz) && nz > 0.01F;
        if (channels == 4) {
          const std::size_t a = static_cast<std::size_t>(c) * 4 + 3;
          ok = ok && (depth == CV_8U    ? alpha8[a] != 0
                      : depth == CV_16U ? alpha16[a] != 0
                                        : alpha32[a] > 0.0F);
        }
        p[c] = ok ? -nx / nz : nan;
        q[c] = ok ? -ny / nz : nan;
      }
    }
  });
  return out;
}

cv::Mat encode_height16(const cv::Mat& height, double low, double high) {
  cv::Mat out;
  const double range = high > low ? high - low : 1.0;
  height.convertTo(out, CV_16U, 65535.0 / range, -low * 65535.0 / range);
  return out;
}

}  // namespace psrig::formats
