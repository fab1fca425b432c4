#include "psrig/calibration/sphere.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <opencv2/imgproc.hpp>

#include "psrig/base/median.h"

namespace psrig::calibration {
namespace {

constexpr int kRays = 720;  // edge points looked for round the circle

double bilinear(const cv::Mat& image, double x, double y) {
  x = std::clamp(x, 0.0, image.cols - 1.0);
  y = std::clamp(y, 0.0, image.rows - 1.0);
  const int x0 = std::min(static_cast<int>(x), image.cols - 2 < 0 ? 0 : image.cols - 2);
  const int y0 = std::min(static_cast<int>(y), image.rows - 2 < 0 ? 0 : image.rows - 2);
  const int x1 = std::min(x0 + 1, image.cols - 1);
  const int y1 = std::min(y0 + 1, image.rows - 1);
  const double fx = x - x0;
  const double fy = y - y0;
  const auto at = [&](int r, int c) { return static_cast<double>(image.at<float>(r, c)); };
  return (1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x1)) +
         fy * ((1 - fx) * at(y1, x0) + fx * at(y1, x1));
}

// Edge points: on each ray from the circle's centre, where the silhouette
// crosses halfway between its levels just inside and just outside the circle.
// `near`: the circle is already within a pixel or two, so the levels come
// from just either side of the edge (a shaded sphere's brightness changes
// toward its rim).
std::vector<cv::Point2d> edge_points(const cv::Mat& silhouette, const Circle& circle, bool near) {
  std::vector<cv::Point2d> points;
  const double r = circle.radius;
  const double step = 0.25;
  const double from = std::max(0.0, r - std::max(4.0, 0.12 * r));
  const double to = r + std::max(4.0, 0.12 * r);
  std::vector<double> profile;
  std::vector<double> contrasts;
  for (int k = 0; k < kRays; ++k) {
    const double angle = 2 * std::numbers::pi * k / kRays;
    const double c = std::cos(angle);
    const double s = std::sin(angle);
    profile.clear();
    std::vector<double> inside;
    std::vector<double> outside;
    for (double t = from; t <= to; t += step) {
      const double x = circle.centre.x + t * c;
      const double y = circle.centre.y + t * s;
      if (x < 0 || y < 0 || x > silhouette.cols - 1 || y > silhouette.rows - 1) break;
      const double v = bilinear(silhouette, x, y);
      profile.push_back(v);
      const double gap = near ? 1.5 : std::max(2.0, 0.05 * r);
      const double band = near ? 2.0 : to - r;
      if (t < r - gap && t >= r - gap - band) inside.push_back(v);
      if (t > r + gap && t <= r + gap + band) outside.push_back(v);
    }
    if (inside.size() < 3 || outside.size() < 3) continue;
    const double in = median(inside);
    const double out = median(outside);
    if (in - out <= 0) continue;
    const double mid = (in + out) / 2;
    // The crossing nearest the circle.
    double best = -1;
    for (std::size_t i = 0; i + 1 < profile.size(); ++i) {
      if ((profile[i] >= mid) == (profile[i + 1] >= mid)) continue;
      const double f = (profile[i] - mid) / (profile[i] - profile[i + 1]);
      const double t = from + (static_cast<double>(i) + f) * step;
      if (best < 0 || std::abs(t - r) < std::abs(best - r)) best = t;
    }
    if (best > 0) {
      points.emplace_back(circle.centre.x + best * c, circle.centre.y + best * s);
      contrasts.push_back(in - out);
    }
  }
  // Where the sphere's rim is barely brighter than what lies behind it (a
  // chrome sphere's dim edge against lit cloth) the crossing says little:
  // only rays with a third of the typical contrast or more count.
  const double typical = median(contrasts);
  std::vector<cv::Point2d> clear;
  for (std::size_t i = 0; i < points.size(); ++i)
    if (contrasts[i] >= typical / 3) clear.push_back(points[i]);
  return clear;
}

std::vector<double> residuals(const std::vector<cv::Point2d>& points, const Circle& circle) {
  std::vector<double> out;
  out.reserve(points.size());
  for (const auto& p : points)
    out.push_back(std::hypot(p.x - circle.centre.x, p.y - circle.centre.y) - circle.radius);
  return out;
}

}  // namespace

Circle fit_circle(const std::vector<cv::Point2d>& points) {
  Circle circle;
  if (points.size() < 3) return circle;
  // Kasa: x^2 + y^2 = a x + b y + c, about the points' mean for conditioning.
  cv::Point2d mean(0, 0);
  for (const auto& p : points)
    mean += p;
  mean *= 1.0 / static_cast<double>(points.size());
  cv::Matx33d ata = cv::Matx33d::zeros();
  cv::Vec3d atb(0, 0, 0);
  for (const auto& p : points) {
    const double x = p.x - mean.x;
    const double y = p.y - mean.y;
    const cv::Vec3d row(x, y, 1);
    ata += row * row.t();
    atb += row * (x * x + y * y);
  }
  const cv::Vec3d abc = ata.solve(atb, cv::DECOMP_LU);
  double cx = abc[0] / 2;
  double cy = abc[1] / 2;
  double r = std::sqrt(std::max(0.0, abc[2] + cx * cx + cy * cy));
  // Gauss-Newton on the geometric distances.
  for (int iteration = 0; iteration < 20; ++iteration) {
    cv::Matx33d jtj = cv::Matx33d::zeros();
    cv::Vec3d jtr(0, 0, 0);
    for (const auto& p : points) {
      const double dx = p.x - mean.x - cx;
      const double dy = p.y - mean.y - cy;
      const double d = std::hypot(dx, dy);
      if (d < 1e-12) continue;
      const cv::Vec3d j(-dx / d, -dy / d, -1);
      const double res = d - r;
      jtj += j * j.t();
      jtr += j * res;
    }
    if (std::abs(cv::determinant(jtj)) < 1e-300) break;
    const cv::Vec3d delta = jtj.solve(-jtr, cv::DECOMP_LU);
    cx += delta[0];
    cy += delta[1];
    r += delta[2];
    if (cv::norm(delta) < 1e-9) break;
  }
  circle.centre = {cx + mean.x, cy + mean.y};
  circle.radius = r;
  circle.points = static_cast<int>(points.size());
  double sum = 0;
  for (const double e : residuals(points, circle))
    sum += e * e;
  circle.rms_px = std::sqrt(sum / static_cast<double>(points.size()));
  return circle;
}

Result<Circle> find_sphere(const std::vector<cv::Mat>& images, const cv::Mat& mask,
                           const std::filesystem::path& source) {
  cv::Mat silhouette;
  if (!mask.empty()) {
    cv::Mat grey = mask;
    if (grey.channels() > 1) {
      std::vector<cv::Mat> planes;
      cv::split(grey, planes);
      grey = planes[0];
    }
    cv::Mat nonzero;
    cv::compare(grey, 0, nonzero, cv::CMP_NE);
    nonzero.convertTo(silhouette, CV_32F, 1.0 / 255);
  } else {
    if (images.empty())
      return std::unexpected(bad_input(source, "", "no images to find the sphere in"));
    silhouette = images.front().clone();
    for (const auto& image : images)
      cv::max(silhouette, image, silhouette);
  }
  const auto not_found = [&](const std::string& why) {
    return std::unexpected(bad_input(
        source, "",
        "no sphere found: " + why +
            "; put the whole sphere in view against a darker background, or give its mask "
            "(--mask: nonzero on the sphere)"));
  };
  // A first outline: the largest blob above Otsu's threshold.
  double low = 0;
  double high = 0;
  cv::minMaxLoc(silhouette, &low, &high);
  if (!(high > low)) return not_found("the image is uniform");
  // Scale to 8 bits below the brightest 0.5 % (highlights), for Otsu.
  cv::Mat clipped;
  {
    std::vector<float> values(silhouette.begin<float>(), silhouette.end<float>());
    auto at = values.begin() + static_cast<std::ptrdiff_t>(values.size() * 995 / 1000);
    std::nth_element(values.begin(), at, values.end());
    double top = *at;
    if (!(top > low)) top = high;
    silhouette.convertTo(clipped, CV_8U, 255.0 / (top - low), -255.0 * low / (top - low));
  }
  cv::Mat binary;
  cv::threshold(clipped, binary, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  cv::morphologyEx(binary, binary, cv::MORPH_OPEN,
                   cv::getStructuringElement(cv::MORPH_ELLIPSE, {5, 5}));
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(binary, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  const std::vector<cv::Point>* largest = nullptr;
  double largest_area = 0;
  for (const auto& contour : contours) {
    const double area = cv::contourArea(contour);
    if (area > largest_area) {
      largest_area = area;
      largest = &contour;
    }
  }
  if (!largest || largest_area < 100) return not_found("nothing bright and large enough");
  std::vector<cv::Point2d> outline(largest->begin(), largest->end());
  Circle circle = fit_circle(outline);
  const double fill = largest_area / (std::numbers::pi * circle.radius * circle.radius);
  if (!(circle.radius > 5) || fill < 0.7 || fill > 1.3)
    return not_found("the largest bright blob is not round (it fills " +
                     std::to_string(static_cast<int>(std::lround(fill * 100))) +
                     " % of its circle)");

  // Sub-pixel: edge points on rays, robust refits.
  for (int pass = 0; pass < 3; ++pass) {
    auto points = edge_points(silhouette, circle, pass > 0);
    if (points.size() < 60) return not_found("its outline is not clear enough");
    Circle fitted = fit_circle(points);
    auto res = residuals(points, fitted);
    std::vector<double> abs_res;
    for (const double e : res)
      abs_res.push_back(std::abs(e));
    const double mad = median(abs_res);
    const double limit = std::max(0.5, 3 * 1.4826 * mad);
    std::vector<cv::Point2d> kept;
    for (std::size_t i = 0; i < points.size(); ++i)
      if (std::abs(res[i]) <= limit) kept.push_back(points[i]);
    if (kept.size() < 60) return not_found("its outline is not round");
    circle = fit_circle(kept);
  }
  // A sphere's outline is a circle all round: most rays find its edge, and
  // on the circle. A cat, a bust or a chrome sphere's dim reflections do not.
  if (circle.points < kRays * 3 / 4 || circle.rms_px > 0.8)
    return not_found(
        "the brightest round blob is not a sphere's outline (" + std::to_string(circle.points) +
        " of " + std::to_string(kRays) + " rays find its edge on one circle, " +
        std::to_string(std::lround(circle.rms_px * 100) / 100.0).substr(0, 4) + " px RMS off it)");
  if (circle.centre.x - circle.radius < -1 || circle.centre.y - circle.radius < -1 ||
      circle.centre.x + circle.radius > silhouette.cols ||
      circle.centre.y + circle.radius > silhouette.rows)
    return not_found("the sphere runs off the image");
  return circle;
}

}  // namespace psrig::calibration
