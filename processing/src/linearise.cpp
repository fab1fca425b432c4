#include "psrig/processing/linearise.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "psrig/base/vector_clones.h"

namespace psrig::processing {
namespace {

// IEC 61966-2-1 sRGB decoding, extended to values outside [0, 1] (float
// frames) by odd symmetry and the same curve above 1.
double srgb_to_linear(double encoded) {
  const double magnitude = std::abs(encoded);
  const double linear =
      magnitude <= 0.04045 ? magnitude / 12.92 : std::pow((magnitude + 0.055) / 1.055, 2.4);
  return std::copysign(linear, encoded);
}

// Blur applied to flat-field frames: the LED pattern is smooth, the noise of
// a single white-target frame is not, and dividing by noise adds noise.
constexpr double kFlatBlurSigma = 2.0;
// Flat-field values below this fraction of the flat's mean are treated as
// this: an unlit corner must not turn into an enormous gain.
constexpr double kFlatFloor = 0.01;

// Stored values to linear: x * scale + offset, for each integer depth.
PSRIG_VECTOR_CLONES
void scale_u8(const std::uint8_t* __restrict src, int n, float scale, float offset,
              float* __restrict out) {
  for (int i = 0; i < n; ++i)
    out[i] = static_cast<float>(src[i]) * scale + offset;
}
PSRIG_VECTOR_CLONES
void scale_u16(const std::uint16_t* __restrict src, int n, float scale, float offset,
               float* __restrict out) {
  for (int i = 0; i < n; ++i)
    out[i] = static_cast<float>(src[i]) * scale + offset;
}
// Interleaved BGR stored values to three planes, x * scale[c] + offset[c],
// and saturated[i] = 1 where any of the three reaches white: one pass, as
// the saturation check shares the loads and shuffles.
struct ChannelAffine {
  float scale[3];
  float offset[3];
};
template <class T>
void deinterleave_affine(const T* __restrict src, int n, ChannelAffine a, T white,
                         float* __restrict b, float* __restrict g, float* __restrict r,
                         std::uint8_t* __restrict saturated) {
  for (int i = 0; i < n; ++i) {
    const T vb = src[3 * i], vg = src[3 * i + 1], vr = src[3 * i + 2];
    b[i] = static_cast<float>(vb) * a.scale[0] + a.offset[0];
    g[i] = static_cast<float>(vg) * a.scale[1] + a.offset[1];
    r[i] = static_cast<float>(vr) * a.scale[2] + a.offset[2];
    saturated[i] = (vb >= white) | (vg >= white) | (vr >= white);
  }
}
PSRIG_VECTOR_CLONES
void deinterleave_u8(const std::uint8_t* src, int n, ChannelAffine a, std::uint8_t white, float* b,
                     float* g, float* r, std::uint8_t* saturated) {
  deinterleave_affine(src, n, a, white, b, g, r, saturated);
}
PSRIG_VECTOR_CLONES
void deinterleave_u16(const std::uint16_t* src, int n, ChannelAffine a, std::uint16_t white,
                      float* b, float* g, float* r, std::uint8_t* saturated) {
  deinterleave_affine(src, n, a, white, b, g, r, saturated);
}

// saturated[i] = 1 where any of pixel i's `channels` values reaches white.
template <class T, int C>
void saturation(const T* __restrict src, int n, T white, std::uint8_t* __restrict saturated) {
  for (int i = 0; i < n; ++i) {
    bool any = false;
    for (int c = 0; c < C; ++c)
      any |= src[C * i + c] >= white;
    saturated[i] = any;
  }
}
PSRIG_VECTOR_CLONES
void saturation_u8(const std::uint8_t* src, int n, int channels, std::uint8_t white,
                   std::uint8_t* saturated) {
  if (channels == 1)
    saturation<std::uint8_t, 1>(src, n, white, saturated);
  else
    saturation<std::uint8_t, 3>(src, n, white, saturated);
}
PSRIG_VECTOR_CLONES
void saturation_u16(const std::uint16_t* src, int n, int channels, std::uint16_t white,
                    std::uint8_t* saturated) {
  if (channels == 1)
    saturation<std::uint16_t, 1>(src, n, white, saturated);
  else
    saturation<std::uint16_t, 3>(src, n, white, saturated);
}
void saturation_f32(const float* src, int n, int channels, float white, std::uint8_t* saturated) {
  if (channels == 1)
    saturation<float, 1>(src, n, white, saturated);
  else
    saturation<float, 3>(src, n, white, saturated);
}

template <class T>
void lookup(const T* __restrict src, int n, const float* __restrict table, float* __restrict out) {
  for (int i = 0; i < n; ++i)
    out[i] = table[src[i]];
}

PSRIG_VECTOR_CLONES
void subtract(float* __restrict values, const float* __restrict dark, int n) {
  for (int i = 0; i < n; ++i)
    values[i] -= dark[i];
}
PSRIG_VECTOR_CLONES
void multiply(float* __restrict values, const float* __restrict gain, float factor, int n) {
  for (int i = 0; i < n; ++i)
    values[i] *= gain[i] * factor;
}
PSRIG_VECTOR_CLONES
void scale_in_place(float* __restrict values, float factor, int n) {
  for (int i = 0; i < n; ++i)
    values[i] *= factor;
}

}  // namespace

CodeLineariser::CodeLineariser(formats::Encoding encoding, double black_level, double white_level,
                               int depth)
    : encoding_(encoding), black_(black_level), white_(white_level), depth_(depth) {
  const double full = formats::full_scale(depth);
  const auto decode = [&](double code) {
    return encoding == formats::Encoding::srgb ? srgb_to_linear(code / full) * full : code;
  };
  const double black_linear = decode(black_level);
  const double range = decode(white_level) - black_linear;
  scale_ = static_cast<float>(1.0 / range);
  offset_ = static_cast<float>(-black_linear / range);
  if (encoding == formats::Encoding::srgb && depth != CV_32F) {
    table_.resize(static_cast<std::size_t>(full) + 1);
    for (std::size_t code = 0; code < table_.size(); ++code)
      table_[code] = static_cast<float>((decode(static_cast<double>(code)) - black_linear) / range);
  }
}

float CodeLineariser::operator()(double stored) const {
  if (encoding_ == formats::Encoding::linear) return static_cast<float>(stored) * scale_ + offset_;
  const double full = formats::full_scale(depth_);
  return static_cast<float>(srgb_to_linear(stored / full) * full) * scale_ + offset_;
}

void CodeLineariser::convert(const void* stored, int count, float* linear, float factor) const {
  switch (depth_) {
    case CV_8U:
      if (table_.empty())
        scale_u8(static_cast<const std::uint8_t*>(stored), count, scale_ * factor, offset_ * factor,
                 linear);
      else
        lookup(static_cast<const std::uint8_t*>(stored), count, table_.data(), linear);
      break;
    case CV_16U:
      if (table_.empty())
        scale_u16(static_cast<const std::uint16_t*>(stored), count, scale_ * factor,
                  offset_ * factor, linear);
      else
        lookup(static_cast<const std::uint16_t*>(stored), count, table_.data(), linear);
      break;
    default: {
      const auto* values = static_cast<const float*>(stored);
      for (int i = 0; i < count; ++i)
        linear[i] = (*this)(values[i]);
    }
  }
  if (factor != 1.0f && (!table_.empty() || depth_ == CV_32F))
    scale_in_place(linear, factor, count);
}

Result<ScanLineariser> ScanLineariser::create(const formats::Scan& scan) {
  if (scan.frames.empty())
    return std::unexpected(internal_error("ScanLineariser: scan has no frames"));
  ScanLineariser result(scan,
                        CodeLineariser(scan.description.encoding, scan.description.black_level,
                                       scan.white_level, scan.depth()));
  const int channels = result.channels_;

  for (const auto& light : scan.description.lights)
    result.inverse_intensity_.emplace_back(static_cast<float>(1.0 / light.intensity_bgr[0]),
                                           static_cast<float>(1.0 / light.intensity_bgr[1]),
                                           static_cast<float>(1.0 / light.intensity_bgr[2]));

  const auto linear_planes = [&](const cv::Mat& stored) {
    cv::Mat linear(stored.size(), CV_32FC(channels));
    for (int r = 0; r < stored.rows; ++r)
      result.codes_.convert(stored.ptr(r), stored.cols * channels, linear.ptr<float>(r));
    std::vector<cv::Mat> planes;
    cv::split(linear, planes);
    return planes;
  };

  // The dark frame is linearised a row at a time as each row is (row()),
  // not kept whole in floats (144 MB at 12 MP colour); the flats need it
  // whole for a moment.
  std::vector<cv::Mat> dark_planes;
  if (!scan.dark.empty() && !scan.flats.empty()) dark_planes = linear_planes(scan.dark);

  // Flat fields: F_k, a white target facing the camera under LED k, holds
  // the LED's pattern and brightness times the target's incidence term
  // l_k.z. Dividing by F_k / l_k.z evens out both, so the lights agree;
  // one constant for the whole scan (the flats' mean level) keeps albedo on
  // the scale of the frames.
  std::vector<std::vector<cv::Mat>> flats;  // per light, per channel: F_k / l_k.z, smoothed
  double level = 0;
  for (std::size_t k = 0; k < scan.flats.size(); ++k) {
    auto planes = linear_planes(scan.flats[k]);
    const double incidence = scan.description.lights[k].direction[2];
    for (int c = 0; c < channels; ++c) {
      cv::Mat& flat = planes[c];
      if (!dark_planes.empty()) flat -= dark_planes[c];
      cv::GaussianBlur(flat, flat, cv::Size(), kFlatBlurSigma);
      flat /= incidence;
      const double mean = cv::mean(flat)[0];
      if (!(mean > 0))
        return std::unexpected(
            bad_input(scan.description.directory / scan.description.flats[k],
                      "flats[" + std::to_string(k) + "]",
                      "is black (after dark subtraction): a flat is a white target under the LED"));
      cv::max(flat, kFlatFloor * mean, flat);
      level += mean;
    }
    flats.push_back(std::move(planes));
  }
  if (!flats.empty()) level /= static_cast<double>(flats.size() * channels);
  for (auto& planes : flats) {
    std::vector<cv::Mat> gains;
    for (auto& flat : planes) {
      cv::Mat gain;
      cv::divide(level, flat, gain, 1.0, CV_32F);
      gains.push_back(gain);
    }
    result.gains_.push_back(std::move(gains));
  }
  return result;
}

ScanLineariser::ScanLineariser(const formats::Scan& scan, CodeLineariser codes)
    : scan_(&scan),
      codes_(codes),
      channels_(scan.channels()),
      cols_(scan.size().width),
      rows_(scan.size().height) {
  if (scan.depth() != CV_32F) white_code_ = static_cast<std::uint64_t>(std::ceil(scan.white_level));
}

void ScanLineariser::row(int light, int row, float* const* planes, std::uint8_t* saturated) const {
  const cv::Mat& frame = scan_->frames[light];
  const void* src = frame.ptr(row);
  const int n = cols_;
  // Without dark or flat the light's intensity folds into the conversion.
  const bool dark = !scan_->dark.empty();
  const bool corrected = dark || !gains_.empty();
  const cv::Vec3f& inverse_intensity = inverse_intensity_[light];
  const auto white_u8 = static_cast<std::uint8_t>(std::min<std::uint64_t>(white_code_, 255));
  const auto white_u16 = static_cast<std::uint16_t>(std::min<std::uint64_t>(white_code_, 65535));
  // Affine colour from integers checks saturation as it deinterleaves.
  const bool deinterleaving = channels_ == 3 && codes_.is_linear() && frame.depth() != CV_32F;

  if (!deinterleaving) {
    switch (frame.depth()) {
      case CV_8U:
        saturation_u8(static_cast<const std::uint8_t*>(src), n, channels_, white_u8, saturated);
        break;
      case CV_16U:
        saturation_u16(static_cast<const std::uint16_t*>(src), n, channels_, white_u16, saturated);
        break;
      default:
        saturation_f32(static_cast<const float*>(src), n, channels_,
                       static_cast<float>(scan_->white_level), saturated);
    }
  }

  if (channels_ == 1) {
    codes_.convert(src, n, planes[0], corrected ? 1.0f : inverse_intensity[0]);
  } else if (deinterleaving) {
    ChannelAffine affine{};
    for (int c = 0; c < 3; ++c) {
      const float factor = corrected ? 1.0f : inverse_intensity[c];
      affine.scale[c] = codes_.scale() * factor;
      affine.offset[c] = codes_.offset() * factor;
    }
    if (frame.depth() == CV_8U)
      deinterleave_u8(static_cast<const std::uint8_t*>(src), n, affine, white_u8, planes[0],
                      planes[1], planes[2], saturated);
    else
      deinterleave_u16(static_cast<const std::uint16_t*>(src), n, affine, white_u16, planes[0],
                       planes[1], planes[2], saturated);
  } else {
    // sRGB tables and float frames: split first, then convert each plane.
    thread_local cv::Mat split[3];
    cv::split(frame.row(row), split);
    for (int c = 0; c < 3; ++c)
      codes_.convert(split[c].data, n, planes[c], corrected ? 1.0f : inverse_intensity[c]);
  }
  if (!corrected) return;

  // The dark row, linear, one plane after another.
  thread_local std::vector<float> dark_row, dark_plane;
  if (dark) {
    dark_row.resize(static_cast<std::size_t>(n) * channels_);
    codes_.convert(scan_->dark.ptr(row), n * channels_, dark_row.data());
    dark_plane.resize(static_cast<std::size_t>(n));
  }
  for (int c = 0; c < channels_; ++c) {
    if (dark) {
      for (int i = 0; i < n; ++i)
        dark_plane[static_cast<std::size_t>(i)] =
            dark_row[static_cast<std::size_t>(i) * channels_ + c];
      subtract(planes[c], dark_plane.data(), n);
    }
    if (!gains_.empty())
      multiply(planes[c], gains_[light][c].ptr<float>(row), inverse_intensity[c], n);
    else
      scale_in_place(planes[c], inverse_intensity[c], n);
  }
}

cv::Mat ScanLineariser::frame(int light) const {
  std::vector<cv::Mat> planes(channels_);
  for (auto& plane : planes)
    plane.create(rows_, cols_, CV_32F);
  std::vector<std::uint8_t> saturated(cols_);
  std::vector<float*> pointers(channels_);
  for (int r = 0; r < rows_; ++r) {
    for (int c = 0; c < channels_; ++c)
      pointers[c] = planes[c].ptr<float>(r);
    row(light, r, pointers.data(), saturated.data());
  }
  cv::Mat merged;
  cv::merge(planes, merged);
  return merged;
}

}  // namespace psrig::processing
