#include "psrig/calibration/light_calibration.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <opencv2/imgproc.hpp>

#include "psrig/base/median.h"

namespace psrig::calibration {
namespace {

constexpr double kDeg = 180 / std::numbers::pi;

cv::Vec3d unit(const cv::Vec3d& v) {
  return v / cv::norm(v);
}

cv::Vec3d reflect(const cv::Vec3d& n, const cv::Vec3d& v) {
  return unit(2 * n.dot(v) * n - v);
}

// The pixels of the image inside the circle shrunk by `margin` pixels.
cv::Mat disc_mask(cv::Size size, const Circle& sphere, double shrink) {
  cv::Mat mask(size, CV_8U, cv::Scalar(0));
  const double r = sphere.radius - shrink;
  for (int row = 0; row < size.height; ++row) {
    auto* line = mask.ptr<std::uint8_t>(row);
    for (int col = 0; col < size.width; ++col)
      if (std::hypot(col - sphere.centre.x, row - sphere.centre.y) < r) line[col] = 255;
  }
  return mask;
}

struct Highlight {
  cv::Point2d centroid;
  double spread_px = 0;  // intensity-weighted RMS radius
  int pixels = 0;
};

// The highlight of one frame: inside the sphere, the saturated pixels (or,
// with none, those above half-way from the sphere's median to its peak),
// their largest blob by summed brightness, and its centroid weighted by how
// far each pixel of the blob (grown by two pixels) stands above half-way.
std::optional<Highlight> find_highlight(const cv::Mat& image, const cv::Mat& disc,
                                        double saturation) {
  double peak = 0;
  cv::minMaxLoc(image, nullptr, &peak, nullptr, nullptr, disc);
  std::vector<double> values;
  for (int row = 0; row < image.rows; row += 2)
    for (int col = 0; col < image.cols; col += 2)
      if (disc.at<std::uint8_t>(row, col)) values.push_back(image.at<float>(row, col));
  const double background = median(values);
  // A highlight stands out: saturated over a sphere well below saturation,
  // or at least thrice the sphere's median and a tenth of full scale above it.
  const bool stands_out = (peak >= saturation && background < 0.5 * saturation) ||
                          peak >= std::max(3 * background, background + 0.1);
  if (!stands_out) return std::nullopt;
  const double level = peak >= saturation ? saturation : background + 0.5 * (peak - background);
  cv::Mat above;
  cv::compare(image, level, above, cv::CMP_GE);
  above &= disc;
  cv::Mat labels;
  cv::Mat stats;
  cv::Mat centroids;
  const int count = cv::connectedComponentsWithStats(above, labels, stats, centroids, 8, CV_32S);
  if (count < 2) return std::nullopt;
  std::vector<double> energy(count, 0);
  for (int row = 0; row < image.rows; ++row)
    for (int col = 0; col < image.cols; ++col)
      if (const int label = labels.at<int>(row, col); label > 0)
        energy[label] += image.at<float>(row, col) - background;
  const int best =
      static_cast<int>(std::max_element(energy.begin() + 1, energy.end()) - energy.begin());
  cv::Mat blob;
  cv::compare(labels, best, blob, cv::CMP_EQ);
  cv::Mat grown;
  cv::dilate(blob, grown, cv::getStructuringElement(cv::MORPH_ELLIPSE, {5, 5}));
  grown &= disc;
  const double half = background + 0.5 * (std::min(peak, 1.0) - background);
  double sw = 0, sx = 0, sy = 0, sxx = 0, syy = 0;
  for (int row = 0; row < image.rows; ++row)
    for (int col = 0; col < image.cols; ++col) {
      if (!grown.at<std::uint8_t>(row, col)) continue;
      const double w = std::max(0.0, static_cast<double>(image.at<float>(row, col)) - half);
      sw += w;
      sx += w * col;
      sy += w * row;
      sxx += w * col * col;
      syy += w * row * row;
    }
  if (!(sw > 0)) return std::nullopt;
  Highlight h;
  h.centroid = {sx / sw, sy / sw};
  h.spread_px = std::sqrt(std::max(0.0, sxx / sw - h.centroid.x * h.centroid.x) +
                          std::max(0.0, syy / sw - h.centroid.y * h.centroid.y));
  h.pixels = stats.at<int>(best, cv::CC_STAT_AREA);
  return h;
}

std::optional<cv::Vec3d> chrome_direction(const Circle& sphere, cv::Point2d pixel,
                                          const CameraModel& camera, cv::Size size) {
  auto n = sphere_normal(sphere, pixel, camera, size);
  if (!n) return std::nullopt;
  return reflect(*n, view_direction(pixel, camera, size));
}

cv::Mat average(const LightFrames& light) {
  cv::Mat sum = cv::Mat::zeros(light.frames.front().image.size(), CV_32F);
  for (const auto& frame : light.frames)
    sum += frame.image;
  return sum / static_cast<double>(light.frames.size());
}

Status check_frames(const std::vector<LightFrames>& lights) {
  if (lights.empty()) return std::unexpected(bad_input({}, "", "no images of the sphere"));
  const cv::Size size =
      lights.front().frames.empty() ? cv::Size() : lights.front().frames.front().image.size();
  for (const auto& light : lights) {
    if (light.frames.empty()) return std::unexpected(bad_input({}, "", "a light has no frames"));
    for (const auto& frame : light.frames)
      if (frame.image.size() != size || frame.image.type() != CV_32F)
        return std::unexpected(bad_input(
            frame.file, "",
            "is " + std::to_string(frame.image.cols) + "x" + std::to_string(frame.image.rows) +
                " but the first frame is " + std::to_string(size.width) + "x" +
                std::to_string(size.height) + "; every image of a calibration shares one size"));
  }
  return {};
}

}  // namespace

double tilt_deg(const cv::Vec3d& d) {
  double t = std::atan2(d[1], d[0]) * kDeg;
  if (t < 0) t += 360;
  return t >= 360 - 1e-6 ? 0 : t;
}

double slant_deg(const cv::Vec3d& d) {
  return std::acos(std::clamp(d[2] / cv::norm(d), -1.0, 1.0)) * kDeg;
}

double angle_deg(const cv::Vec3d& a, const cv::Vec3d& b) {
  return std::acos(std::clamp(a.dot(b) / (cv::norm(a) * cv::norm(b)), -1.0, 1.0)) * kDeg;
}

cv::Vec3d view_direction(cv::Point2d pixel, const CameraModel& camera, cv::Size size) {
  if (!camera.focal_px) return {0, 0, 1};
  const double f = *camera.focal_px;
  const cv::Point2d principal((size.width - 1) / 2.0, (size.height - 1) / 2.0);
  // Toward the camera: the opposite of the ray into the scene.
  return unit(cv::Vec3d(-(pixel.x - principal.x) / f, (pixel.y - principal.y) / f, 1));
}

std::optional<cv::Vec3d> sphere_normal(const Circle& sphere, cv::Point2d pixel,
                                       const CameraModel& camera, cv::Size size) {
  if (!camera.focal_px) {
    const double x = (pixel.x - sphere.centre.x) / sphere.radius;
    const double y = -(pixel.y - sphere.centre.y) / sphere.radius;
    const double r2 = x * x + y * y;
    if (r2 >= 1) return std::nullopt;
    return cv::Vec3d(x, y, std::sqrt(1 - r2));
  }
  // Perspective: a unit sphere at the distance its angular radius gives,
  // on the ray through the circle's centre; the pixel's ray meets it.
  const cv::Vec3d to_centre = -view_direction(sphere.centre, camera, size);
  const cv::Vec3d to_rim =
      -view_direction(sphere.centre + cv::Point2d(sphere.radius, 0), camera, size);
  const double sin_radius = std::sin(std::acos(std::clamp(to_centre.dot(to_rim), -1.0, 1.0)));
  const cv::Vec3d centre = to_centre / sin_radius;
  const cv::Vec3d ray = -view_direction(pixel, camera, size);
  const double b = ray.dot(centre);
  const double disc = b * b - centre.dot(centre) + 1;
  if (disc <= 0) return std::nullopt;
  const double t = b - std::sqrt(disc);
  return unit(t * ray - centre);
}

Result<std::vector<LightEstimate>> calibrate_chrome(const std::vector<LightFrames>& lights,
                                                    const Circle& sphere, const CameraModel& camera,
                                                    double saturation) {
  if (auto ok = check_frames(lights); !ok) return std::unexpected(ok.error());
  const cv::Size size = lights.front().frames.front().image.size();
  const cv::Mat disc = disc_mask(size, sphere, 1.0);
  // The sphere's own fit: a centre off by its standard error moves every normal.
  const double sphere_deg =
      2 * kDeg * sphere.rms_px / std::sqrt(std::max(1, sphere.points)) * 2 / sphere.radius;
  std::vector<LightEstimate> estimates;
  for (std::size_t k = 0; k < lights.size(); ++k) {
    LightEstimate estimate;
    std::vector<cv::Vec3d> directions;
    cv::Point2d centroid_sum(0, 0);
    double spread_sum = 0;
    double centroid_deg_sum = 0;
    for (const auto& frame : lights[k].frames) {
      const auto highlight = find_highlight(frame.image, disc, saturation);
      const auto direction =
          highlight ? chrome_direction(sphere, highlight->centroid, camera, size) : std::nullopt;
      if (!direction)
        return std::unexpected(bad_input(
            frame.file, "",
            "no highlight on the chrome sphere for light " + std::to_string(k) +
                " (nothing inside the sphere stands out as much brighter than the rest): check "
                "that this light was on and reflects in the sphere, and retake or leave out the "
                "frame"));
      // The highlight's size as an angle: the direction one spread away.
      const cv::Point2d offset = highlight->centroid - sphere.centre;
      const double length = std::hypot(offset.x, offset.y);
      const cv::Point2d along = length > 1e-9 ? offset * (1 / length) : cv::Point2d(1, 0);
      double spread_deg = 0;
      for (const cv::Point2d e : {along, cv::Point2d(-along.y, along.x)}) {
        const cv::Point2d moved = highlight->centroid + e * highlight->spread_px;
        if (const auto other = chrome_direction(sphere, moved, camera, size))
          spread_deg = std::max(spread_deg, angle_deg(*direction, *other));
        else
          spread_deg = std::max(spread_deg, 90.0 - slant_deg(*direction) / 2);
      }
      directions.push_back(*direction);
      centroid_sum += highlight->centroid;
      spread_sum += spread_deg;
      // A centroid over n pixels: about spread / sqrt(n).
      centroid_deg_sum += spread_deg / std::sqrt(std::max(1, highlight->pixels));
    }
    const double n = static_cast<double>(directions.size());
    cv::Vec3d mean(0, 0, 0);
    for (const auto& d : directions)
      mean += d;
    mean = unit(mean);
    double scatter = 0;
    for (const auto& d : directions)
      scatter += std::pow(angle_deg(d, mean), 2);
    scatter = std::sqrt(scatter / n);
    estimate.direction = mean;
    estimate.frames = static_cast<int>(directions.size());
    estimate.highlight_px = centroid_sum * (1 / n);
    estimate.highlight_spread_deg = spread_sum / n;
    estimate.frames_spread_deg = scatter;
    const double centroid_deg = centroid_deg_sum / n / std::sqrt(n);
    const double scatter_deg = directions.size() > 1 ? scatter / std::sqrt(n - 1) : 0;
    estimate.uncertainty_deg = std::sqrt(centroid_deg * centroid_deg + scatter_deg * scatter_deg +
                                         sphere_deg * sphere_deg);
    estimates.push_back(estimate);
  }
  return estimates;
}

Result<std::vector<LightEstimate>> calibrate_matte(const std::vector<LightFrames>& lights,
                                                   const Circle& sphere, const CameraModel& camera,
                                                   double saturation) {
  if (auto ok = check_frames(lights); !ok) return std::unexpected(ok.error());
  const cv::Size size = lights.front().frames.front().image.size();
  // Away from the rim, where the edge blurs into the background.
  const cv::Mat disc = disc_mask(size, sphere, std::max(2.0, 0.03 * sphere.radius));
  std::vector<cv::Point> pixels;
  std::vector<cv::Vec3d> normals;
  cv::findNonZero(disc, pixels);
  for (const auto& p : pixels)
    normals.push_back(sphere_normal(sphere, p, camera, size).value_or(cv::Vec3d(0, 0, 1)));
  std::vector<LightEstimate> estimates;
  for (std::size_t k = 0; k < lights.size(); ++k) {
    const cv::Mat image = average(lights[k]);
    std::vector<double> lit;
    for (const auto& p : pixels)
      lit.push_back(image.at<float>(p));
    std::vector<double> sorted = lit;
    std::sort(sorted.begin(), sorted.end());
    const double bright = sorted[sorted.size() * 99 / 100];
    const double shadow = std::max(0.01, 0.05 * bright);
    cv::Vec3d b(0, 0, 0);
    double residual = 0;
    int used = 0;
    cv::Matx33d ata;
    double limit = 0;  // residuals beyond it are specular glints or dirt (after the first pass)
    const auto keep = [&](std::size_t i, int pass) {
      const double v = lit[i];
      if (v <= shadow || v >= saturation) return false;
      if (pass == 0) return true;
      // Only well-lit facets (not grazing, where penumbrae and
      // inter-reflections bend the cosine law), and no outliers.
      const double predicted = normals[i].dot(b);
      return predicted >= 0.15 * cv::norm(b) && std::abs(v - predicted) <= limit;
    };
    for (int pass = 0; pass < 4; ++pass) {
      if (pass > 0) {
        std::vector<double> deviations;
        for (std::size_t i = 0; i < pixels.size(); ++i)
          if (lit[i] > shadow && lit[i] < saturation && normals[i].dot(b) >= 0.15 * cv::norm(b))
            deviations.push_back(std::abs(lit[i] - normals[i].dot(b)));
        limit = std::max(1e-4, 3 * 1.4826 * median(deviations));
      }
      ata = cv::Matx33d::zeros();
      cv::Vec3d atb(0, 0, 0);
      used = 0;
      for (std::size_t i = 0; i < pixels.size(); ++i) {
        if (!keep(i, pass)) continue;
        ata += normals[i] * normals[i].t();
        atb += normals[i] * lit[i];
        ++used;
      }
      if (used >= 50 && std::abs(cv::determinant(ata)) > 1e-12)
        b = ata.solve(atb, cv::DECOMP_LU);
      else
        return std::unexpected(bad_input(
            lights[k].frames.front().file, "",
            "too few lit pixels on the matte sphere for light " + std::to_string(k) + " (" +
                std::to_string(used) +
                "): check that this light was on and lights the sphere, and that the exposure "
                "neither leaves it dark nor saturates it"));
    }
    double sum = 0;
    const double nb = cv::norm(b);
    for (std::size_t i = 0; i < pixels.size(); ++i)
      if (keep(i, 1)) sum += std::pow(lit[i] - normals[i].dot(b), 2);
    residual = std::sqrt(sum / std::max(1, used));
    // The fit's covariance, sigma^2 (A^T A)^-1, across the direction.
    const cv::Matx33d covariance = ata.inv() * (residual * residual);
    const cv::Vec3d d = b / nb;
    const double across = std::max(0.0, cv::trace(covariance) - d.dot(covariance * d));
    LightEstimate estimate;
    estimate.direction = d;
    estimate.intensity = nb;
    estimate.uncertainty_deg = kDeg * std::sqrt(across / 2) / nb;
    estimate.residual = residual;
    estimate.pixels = used;
    estimate.frames = static_cast<int>(lights[k].frames.size());
    estimates.push_back(estimate);
  }
  double brightest = 0;
  for (const auto& e : estimates)
    brightest = std::max(brightest, e.intensity);
  for (auto& e : estimates)
    e.intensity /= brightest;
  return estimates;
}

Result<std::vector<LedPosition>> triangulate_leds(const std::vector<SpherePlacement>& placements,
                                                  const PlaneGeometry& geometry) {
  if (placements.size() < 2)
    return std::unexpected(bad_input(
        {}, "placements", "the sphere at two or more places is needed to place the LEDs"));
  if (!(geometry.pixel_size_mm > 0))
    return std::unexpected(
        bad_input({}, "pixel_size_mm", "needed to place the LEDs in millimetres"));
  const std::size_t lights = placements.front().lights.size();
  for (const auto& placement : placements)
    if (placement.lights.size() != lights)
      return std::unexpected(bad_input({}, "placements", "every placement needs every light"));
  const double s = geometry.pixel_size_mm;
  const cv::Point2d axis = geometry.principal_point_px.value_or(
      cv::Point2d((geometry.image_size.width - 1) / 2.0, (geometry.image_size.height - 1) / 2.0));
  std::vector<LedPosition> result;
  for (std::size_t k = 0; k < lights; ++k) {
    std::vector<std::pair<cv::Vec3d, cv::Vec3d>> rays;  // origin (mm), unit direction
    for (const auto& placement : placements) {
      const Circle& c = placement.sphere;
      const LightEstimate& e = placement.lights[k];
      if (!e.highlight_px)
        return std::unexpected(
            bad_input({}, "placements", "light " + std::to_string(k) + " has no highlight"));
      const double radius_mm =
          geometry.sphere_diameter_mm > 0 ? geometry.sphere_diameter_mm / 2 : c.radius * s;
      const cv::Vec3d centre((c.centre.x - axis.x) * s, (axis.y - c.centre.y) * s, radius_mm);
      const double dx = (e.highlight_px->x - c.centre.x) / c.radius;
      const double dy = (c.centre.y - e.highlight_px->y) / c.radius;
      const cv::Vec3d n(dx, dy, std::sqrt(std::max(0.0, 1 - dx * dx - dy * dy)));
      rays.emplace_back(centre + radius_mm * n, e.direction / cv::norm(e.direction));
    }
    cv::Matx33d a = cv::Matx33d::zeros();
    cv::Vec3d b(0, 0, 0);
    for (const auto& [o, d] : rays) {
      const cv::Matx33d m = cv::Matx33d::eye() - d * d.t();
      a += m;
      b += m * o;
    }
    cv::Vec3d w;
    cv::SVD::compute(a, w);
    if (!(w[2] > 1e-8 * w[0]))
      return std::unexpected(bad_input({}, "placements",
                                       "the rays of light " + std::to_string(k) +
                                           " do not cross: place the sphere farther apart"));
    LedPosition p;
    p.position_mm = a.solve(b, cv::DECOMP_SVD);
    double sum = 0;
    for (const auto& [o, d] : rays) {
      const cv::Vec3d v = p.position_mm - o;
      sum += (v - v.dot(d) * d).dot(v - v.dot(d) * d);
      for (const auto& other : rays)
        p.baseline_mm = std::max(p.baseline_mm, cv::norm(o - other.first));
    }
    p.ray_rms_mm = std::sqrt(sum / static_cast<double>(rays.size()));
    // The least-squares covariance: the rays' scatter about the point (2
    // constraints a ray, 3 unknowns) through the normal equations' inverse,
    // the scatter no less than the spheres' places are known to (their
    // fits). The highlights' own size is left out: an LED's disc moves
    // every place's highlight alike, not at random.
    double floor_mm = 0;
    for (const auto& placement : placements)
      floor_mm = std::max(
          floor_mm, placement.sphere.rms_px * s / std::sqrt(std::max(1, placement.sphere.points)));
    const int dof = 2 * static_cast<int>(rays.size()) - 3;
    const double scatter = dof > 0 ? sum / dof : p.ray_rms_mm * p.ray_rms_mm;
    const double variance = std::max(scatter, floor_mm * floor_mm);
    const cv::Matx33d covariance = a.inv(cv::DECOMP_SVD) * variance;
    cv::Vec3d variances;
    cv::eigen(covariance, variances);
    p.uncertainty_mm = std::sqrt(std::max(0.0, variances[0]));
    result.push_back(p);
  }
  return result;
}

}  // namespace psrig::calibration
