#include "psrig/sim/sensor.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace psrig::sim {
namespace {

// The exposure at which `led_irradiance` is specified.
constexpr double kReferenceExposureUs = 20000;

// 1 at the centre, 1 - strength at the corners (a cos^4 fall-off, to second
// order), for `rows` of a frame of `size`.
cv::Mat vignette(cv::Size size, cv::Range rows, double strength) {
  cv::Mat v(rows.size(), size.width, CV_32F);
  const double cx = (size.width - 1) / 2.0, cy = (size.height - 1) / 2.0;
  const double corner = cx * cx + cy * cy;
  for (int r = rows.start; r < rows.end; ++r)
    for (int c = 0; c < size.width; ++c)
      v.at<float>(r - rows.start, c) = static_cast<float>(
          1 - strength * ((c - cx) * (c - cx) + (r - cy) * (r - cy)) / std::max(corner, 1.0));
  return v;
}

}  // namespace

Sensor::Sensor(const config::SimConfig& config, std::uint64_t seed)
    : bit_depth_(std::clamp(config.bit_depth, 8, 16)),
      full_well_(std::max(config.full_well, 1.0)),
      read_noise_(std::max(config.read_noise, 0.0)),
      black_level_(config.black_level),
      vignetting_(std::clamp(config.vignetting, 0.0, 0.9)),
      led_irradiance_(config.led_irradiance),
      ambient_(config.ambient),
      seed_(seed) {
  if (config.colour_matrix) {
    // Configured for RGB; the frames are BGR: reverse rows and columns.
    const auto& m = *config.colour_matrix;
    cv::Matx33f bgr;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        bgr(2 - r, 2 - c) = static_cast<float>(m[r * 3 + c]);
    colour_bgr_ = bgr;
  }
}

cv::Mat Sensor::expose(const World& world, Clock::time_point begin, const SensorSettings& settings,
                       std::uint64_t frame_number) const {
  const auto end = begin + std::chrono::microseconds(settings.exposure_us);
  const std::vector<double> weights = world.exposure_weights(begin, end);
  const double scale = settings.gain * settings.exposure_us / kReferenceExposureUs;
  // Electrons: fewer per code at higher gain, so gain raises the noise.
  const double electrons_per_unit = full_well_ / settings.gain;
  const double white = white_level();
  const cv::Size size = world.ambient().size();
  cv::Mat frame(size, CV_16UC(settings.channels == 1 ? 1 : 3));
  cv::RNG random(seed_ * 0x9E3779B97F4A7C15ull + frame_number + 1);
  // A band of rows at a time, so that at 12 MP the working planes are a few
  // MB rather than a GB; the noise is drawn in the same order as for the
  // whole frame at once.
  constexpr int kBandRows = 16;
  for (int top = 0; top < size.height; top += kBandRows) {
    const cv::Range rows(top, std::min(top + kBandRows, size.height));
    // Light reaching the sensor, as a fraction of full scale.
    cv::Mat signal = world.ambient().rowRange(rows) * (ambient_ * led_irradiance_ * scale);
    for (std::size_t k = 0; k < weights.size(); ++k)
      if (weights[k] > 0)
        cv::scaleAdd(world.radiance(static_cast<int>(k)).rowRange(rows),
                     weights[k] * led_irradiance_ * scale, signal, signal);
    if (colour_bgr_) {
      cv::Mat mixed;
      cv::transform(signal, mixed, *colour_bgr_);
      signal = mixed;
    }
    const cv::Mat fall_off = vignette(size, rows, vignetting_);
    cv::Mat fall_off3;
    cv::merge(std::vector<cv::Mat>{fall_off, fall_off, fall_off}, fall_off3);
    signal = signal.mul(fall_off3);
    if (settings.channels == 1)
      cv::transform(signal, signal, cv::Matx13f(1.0f / 3, 1.0f / 3, 1.0f / 3));

    cv::Mat electrons;
    signal.convertTo(electrons, -1, electrons_per_unit);
    cv::max(electrons, cv::Scalar::all(0), electrons);
    cv::Mat sigma;
    electrons.convertTo(sigma, -1, 1.0, read_noise_ * read_noise_);
    cv::sqrt(sigma, sigma);
    cv::Mat noise(signal.size(), signal.type());
    random.fill(noise, cv::RNG::NORMAL, 0.0, 1.0);
    electrons += noise.mul(sigma);

    // To codes: black level plus the signal over the ADC's range.
    cv::Mat codes = frame.rowRange(rows);
    electrons.convertTo(codes, CV_16U, (white - black_level_) / electrons_per_unit,
                        black_level_);  // rounds, clips at 0
    cv::min(codes, white, codes);       // and at the ADC's full scale
  }
  return frame;
}

}  // namespace psrig::sim
