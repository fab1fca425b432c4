#pragma once
// Linearisation: one scan's stored frames to linear, corrected measurements.
// In order: sRGB decoding (when encoding is srgb), black and white level
// (black -> 0, white -> 1), dark-frame subtraction, flat-field division
// (each LED's pattern and brightness, from a white target facing the
// camera under it; with flats, leave the lights' intensities at 1) and the
// light's relative intensity. Stored values at or above the white level are
// reported as saturated.
//
// Works a row at a time into planar float buffers so the solve can consume
// the measurements while they are still in cache (the frames are 12 MP).

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/formats/scan.h"

namespace psrig::processing {

// Stored code value -> linear fraction of full scale, for one scan's encoding.
class CodeLineariser {
 public:
  CodeLineariser(formats::Encoding encoding, double black_level, double white_level, int depth);

  // `count` stored values of the construction depth -> linear floats,
  // multiplied by `factor`.
  void convert(const void* stored, int count, float* linear, float factor = 1.0f) const;
  [[nodiscard]] float operator()(double stored) const;
  // Linear encoding is x * scale() + offset().
  [[nodiscard]] bool is_linear() const { return encoding_ == formats::Encoding::linear; }
  [[nodiscard]] float scale() const { return scale_; }
  [[nodiscard]] float offset() const { return offset_; }

 private:
  formats::Encoding encoding_;
  double black_;
  double white_;
  int depth_;
  float scale_ = 1;  // linear encoding: (x - black) * scale_
  float offset_ = 0;
  std::vector<float> table_;  // srgb encoding, integer depths: one entry per code
};

// Holds a pointer to the scan: it must not outlive it or see it move.
class ScanLineariser {
 public:
  // Precomputes the flat-field gains; the dark frame is linearised a row at
  // a time, as each row is.
  [[nodiscard]] static Result<ScanLineariser> create(const formats::Scan& scan);

  // Row `row` of light `light`: channel c goes to planes[c][0..cols) (BGR
  // order for colour), and saturated[i] is set to 1 where any channel of
  // pixel i is at or above the white level (0 elsewhere).
  void row(int light, int row, float* const* planes, std::uint8_t* saturated) const;

  // The whole corrected frame of one light, CV_32FC(channels), interleaved.
  [[nodiscard]] cv::Mat frame(int light) const;

  [[nodiscard]] int channels() const { return channels_; }
  [[nodiscard]] int cols() const { return cols_; }
  [[nodiscard]] int rows() const { return rows_; }

 private:
  ScanLineariser(const formats::Scan& scan, CodeLineariser codes);

  const formats::Scan* scan_;
  CodeLineariser codes_;
  int channels_ = 1;
  int cols_ = 0;
  int rows_ = 0;
  std::vector<cv::Vec3f> inverse_intensity_;  // per light, BGR
  std::vector<std::vector<cv::Mat>> gains_;   // per light, per channel, CV_32F; empty without flats
  std::uint64_t white_code_ = 0;              // integer frames: first saturated code
};

}  // namespace psrig::processing
