#include "psrig/sim/sphere_target.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <opencv2/imgproc.hpp>

#include "target_sampling.h"

namespace psrig::sim {
namespace {

constexpr double kMirror = 0.6;
constexpr double kChromeDiffuse = 0.04;
constexpr double kMatteAlbedo = 0.5;
constexpr double kVelvet = 0.004;
constexpr double kLensBlurPx = 0.6;

// Radiance of one sample at (dx, dy) pixels from the sphere's centre, y up.
// `direction` empty: the room light.
double sample(const SphereTarget& target, double radius, double dx, double dy,
              const cv::Vec3d* direction, double cos_led) {
  const double d2 = dx * dx + dy * dy;
  if (d2 < radius * radius) {
    const cv::Vec3d n(dx / radius, dy / radius, std::sqrt(1 - d2 / (radius * radius)));
    const double diffuse = target.kind == SphereKind::matte ? kMatteAlbedo : kChromeDiffuse;
    if (!direction) {
      double value = diffuse * (1 + n[2]) / 2;
      if (target.kind == SphereKind::chrome) {
        const double rz = 2 * n[2] * n[2] - 1;  // the reflected view ray's z
        value += kMirror * (rz > 0 ? 1.0 : kVelvet);
      }
      return value;
    }
    double value = diffuse * std::max(0.0, n.dot(*direction));
    if (target.kind == SphereKind::chrome) {
      const cv::Vec3d r = 2 * n[2] * n - cv::Vec3d(0, 0, 1);
      if (r.dot(*direction) >= cos_led) {
        const double sin2 = 1 - cos_led * cos_led;
        value += kMirror / sin2;  // the LED's radiance: unit irradiance from a disc of that size
      }
    }
    return value;
  }
  if (!direction) return kVelvet;
  // The velvet, in the sphere's cast shadow or lit.
  const cv::Vec3d& l = *direction;
  const cv::Vec3d f(dx, dy, -radius);  // from the sphere's centre (resting: height = radius)
  const double b = f.dot(l);
  const double c = f.dot(f) - radius * radius;
  const double disc = b * b - c;
  if (disc > 0 && -b + std::sqrt(disc) > 0) return 0.0;
  return kVelvet * std::max(0.0, l[2]);
}

cv::Mat render(const SphereTarget& target, const cv::Vec3d* direction,
               const cv::Vec3d* position_mm = nullptr) {
  const cv::Point2d centre = target.centre_px();
  const double radius = target.radius_px();
  const double s = target.pixel_size_mm;
  const double axis_x = (target.size.width - 1) / 2.0;
  const double axis_y = (target.size.height - 1) / 2.0;
  const double cos_led = std::cos(target.led_angular_diameter_deg / 2 * std::numbers::pi / 180);
  cv::Mat out(target.size, CV_32FC3);
  for (int row = 0; row < target.size.height; ++row) {
    auto* line = out.ptr<cv::Vec3f>(row);
    for (int col = 0; col < target.size.width; ++col) {
      double sum = 0;
      for (int i = 0; i < kSamplesPerPixel; ++i)
        for (int j = 0; j < kSamplesPerPixel; ++j) {
          const double x = col + (j + 0.5) / kSamplesPerPixel - 0.5;
          const double y = row + (i + 0.5) / kSamplesPerPixel - 0.5;
          if (!position_mm) {
            sum += sample(target, radius, x - centre.x, centre.y - y, direction, cos_led);
            continue;
          }
          // A point source: the direction from this sample's point on the sphere or velvet.
          const double dx = x - centre.x, dy = centre.y - y;
          const double d2 = dx * dx + dy * dy;
          const double z = d2 < radius * radius ? radius + std::sqrt(radius * radius - d2) : 0.0;
          cv::Vec3d toward = *position_mm - cv::Vec3d((x - axis_x) * s, (axis_y - y) * s, z * s);
          toward /= cv::norm(toward);
          sum += sample(target, radius, dx, dy, &toward, cos_led);
        }
      const auto value = static_cast<float>(sum / (kSamplesPerPixel * kSamplesPerPixel));
      line[col] = {value, value, value};
    }
  }
  // The lens's blur (a Gaussian point spread of 0.6 pixels): a real
  // highlight has a soft edge, whatever its saturated core.
  cv::GaussianBlur(out, out, {0, 0}, kLensBlurPx, kLensBlurPx, cv::BORDER_REPLICATE);
  return out;
}

}  // namespace

cv::Point2d SphereTarget::centre_px() const {
  if (centre.x >= 0 && centre.y >= 0) return centre;
  return {(size.width - 1) / 2.0, (size.height - 1) / 2.0};
}

Swatch sphere_scene(const SphereTarget& target) {
  Swatch scene;
  scene.pixel_size_mm = target.pixel_size_mm;
  scene.height_mm = cv::Mat(target.size, CV_32F, cv::Scalar(0));
  scene.normal = cv::Mat(target.size, CV_32FC3, cv::Scalar(0, 0, 1));
  scene.albedo = cv::Mat(target.size, CV_32FC3, cv::Scalar::all(kVelvet));
  const cv::Point2d centre = target.centre_px();
  const double radius = target.radius_px();
  const float albedo = target.kind == SphereKind::matte ? kMatteAlbedo : kChromeDiffuse;
  for (int row = 0; row < target.size.height; ++row)
    for (int col = 0; col < target.size.width; ++col) {
      const double dx = col - centre.x;
      const double dy = centre.y - row;
      const double d2 = dx * dx + dy * dy;
      if (d2 >= radius * radius) continue;
      const double nz = std::sqrt(1 - d2 / (radius * radius));
      scene.normal.at<cv::Vec3f>(row, col) = cv::Vec3f(
          static_cast<float>(dx / radius), static_cast<float>(dy / radius), static_cast<float>(nz));
      scene.height_mm.at<float>(row, col) =
          static_cast<float>((radius + radius * nz) * target.pixel_size_mm);
      scene.albedo.at<cv::Vec3f>(row, col) = cv::Vec3f(albedo, albedo, albedo);
    }
  return scene;
}

cv::Mat render_sphere(const SphereTarget& target, const cv::Vec3d& direction) {
  const cv::Vec3d unit = direction / cv::norm(direction);
  return render(target, &unit);
}

cv::Mat render_sphere_point(const SphereTarget& target, const cv::Vec3d& position_mm) {
  return render(target, nullptr, &position_mm);
}

cv::Mat render_sphere_ambient(const SphereTarget& target) {
  return render(target, nullptr);
}

}  // namespace psrig::sim
