#include "psrig/preview/environment_light.h"

#include <cmath>
#include <numbers>

#include <opencv2/imgproc.hpp>

#include "psrig/cloth/srgb.h"
#include "psrig/formats/image_io.h"

namespace psrig::preview {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;

// Funk-Hecke: a zonal kernel K scales band l by 2 pi int K(x) P_l(x) dx.
// Clamped cosine: pi, 2 pi / 3, pi / 4; over pi for Lambert.
constexpr std::array<float, 3> kLambertBands = {1.0f, 2.0f / 3.0f, 1.0f / 4.0f};
// sqrt(1 - x^2): pi^2, 0, -pi^2 / 8; over pi^2.
constexpr std::array<float, 3> kFibreBands = {1.0f, 0.0f, -1.0f / 8.0f};

constexpr int band_of(int index) {
  return index == 0 ? 0 : index < 4 ? 1 : 2;
}

// The nine coefficients of radiance(w) sampled over a latitude-longitude
// grid, each sample weighted by its solid angle.
template <class Radiance>
std::array<Eigen::Vector3f, 9> project(int rows, int columns, Radiance radiance) {
  std::array<Eigen::Vector3d, 9> sum;
  sum.fill(Eigen::Vector3d::Zero());
  for (int row = 0; row < rows; ++row) {
    const double polar = (row + 0.5) * std::numbers::pi / rows;  // from +y
    const double solid_angle =
        std::sin(polar) * (std::numbers::pi / rows) * (2 * std::numbers::pi / columns);
    for (int column = 0; column < columns; ++column) {
      const double longitude = (column + 0.5) * 2 * std::numbers::pi / columns - std::numbers::pi;
      const Eigen::Vector3f w(static_cast<float>(std::sin(polar) * std::sin(longitude)),
                              static_cast<float>(std::cos(polar)),
                              static_cast<float>(std::sin(polar) * std::cos(longitude)));
      const Eigen::Vector3d value = radiance(row, column, w).template cast<double>() * solid_angle;
      const std::array<float, 9> basis = harmonics(w);
      for (int i = 0; i < 9; ++i)
        sum[i] += value * basis[i];
    }
  }
  std::array<Eigen::Vector3f, 9> coefficients;
  for (int i = 0; i < 9; ++i)
    coefficients[i] = sum[i].cast<float>();
  return coefficients;
}

}  // namespace

std::array<float, 9> harmonics(const Eigen::Vector3f& w) {
  const float x = w.x(), y = w.y(), z = w.z();
  return {0.282095f,
          0.488603f * y,
          0.488603f * z,
          0.488603f * x,
          1.092548f * x * y,
          1.092548f * y * z,
          0.315392f * (3 * z * z - 1),
          1.092548f * x * z,
          0.546274f * (x * x - y * y)};
}

EnvironmentLight EnvironmentLight::from_lobes(const std::vector<RadialLobe>& lobes) {
  EnvironmentLight light;
  light.sh_ = project(128, 256, [&](int, int, const Eigen::Vector3f& w) {
    Eigen::Vector3f sum = Eigen::Vector3f::Zero();
    for (const RadialLobe& lobe : lobes)
      sum += lobe.weight * std::exp(lobe.sharpness * (w.dot(lobe.axis.normalized()) - 1));
    return sum;
  });
  return light;
}

EnvironmentLight EnvironmentLight::studio() {
  return from_lobes({
      {Eigen::Vector3f(0.0f, 0.55f, 1.0f).normalized(), 3.0f, {0.30f, 0.29f, 0.27f}},  // soft box
      {Eigen::Vector3f::UnitY(), 1.0f, {0.06f, 0.07f, 0.09f}},                        // sky
      {-Eigen::Vector3f::UnitY(), 1.5f, {0.07f, 0.06f, 0.05f}},                       // floor
      {Eigen::Vector3f::UnitZ(), 0.0f, {0.025f, 0.025f, 0.025f}},                     // room
  });
}

EnvironmentLight EnvironmentLight::uniform(const Eigen::Vector3f& radiance) {
  EnvironmentLight light;
  // Only the constant band: L00 = radiance * 4 pi * Y00.
  light.sh_[0] = radiance * (4 * kPi * 0.282095f);
  return light;
}

EnvironmentLight EnvironmentLight::from_equirectangular(const cv::Mat& image) {
  cv::Mat linear;
  if (image.depth() == CV_32F) {
    image.convertTo(linear, CV_32F);
  } else {
    const double scale = image.depth() == CV_16U ? 1.0 / 65535.0 : 1.0 / 255.0;
    image.convertTo(linear, CV_32F, scale);
    linear.forEach<float>([](float& value, const int*) { value = cloth::srgb_decode(value); });
  }
  if (linear.channels() == 1) cv::cvtColor(linear, linear, cv::COLOR_GRAY2BGR);
  if (linear.channels() == 4) cv::cvtColor(linear, linear, cv::COLOR_BGRA2BGR);
  const cv::Mat bgr = linear.reshape(3);
  EnvironmentLight light;
  light.sh_ = project(bgr.rows, bgr.cols, [&](int row, int column, const Eigen::Vector3f&) {
    const cv::Vec3f pixel = bgr.at<cv::Vec3f>(row, column);
    return Eigen::Vector3f(pixel[2], pixel[1], pixel[0]);
  });
  return light;
}

Result<EnvironmentLight> EnvironmentLight::load(const std::filesystem::path& file) {
  auto image = formats::read_image(file, "--environment");
  if (!image) return std::unexpected(image.error());
  if (image->empty() || image->cols < 2 * image->rows - 1 || image->cols > 2 * image->rows + 1)
    return std::unexpected(bad_input(file, "--environment",
                                     "an environment map is an equirectangular image, twice as "
                                     "wide as it is high"));
  return from_equirectangular(*image);
}

Eigen::Vector3f EnvironmentLight::convolved(const Eigen::Vector3f& w,
                                            const std::array<float, 3>& bands) const {
  const std::array<float, 9> basis = harmonics(w);
  Eigen::Vector3f sum = Eigen::Vector3f::Zero();
  for (int i = 0; i < 9; ++i)
    sum += sh_[i] * (bands[band_of(i)] * basis[i]);
  return sum;
}

Eigen::Vector3f EnvironmentLight::radiance(const Eigen::Vector3f& w) const {
  return convolved(w, {1, 1, 1});
}

Eigen::Vector3f EnvironmentLight::lambert(const Eigen::Vector3f& normal) const {
  return convolved(normal, kLambertBands);
}

Eigen::Vector3f EnvironmentLight::fibre(const Eigen::Vector3f& tangent) const {
  return convolved(tangent, kFibreBands);
}

}  // namespace psrig::preview
