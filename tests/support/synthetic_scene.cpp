#include "synthetic_scene.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include "psrig/formats/light_matrix.h"

namespace psrig::test {

std::vector<cv::Vec3d> ring_lights(int count, double slant_deg, double first_tilt_deg) {
  std::vector<cv::Vec3d> lights;
  for (int k = 0; k < count; ++k)
    lights.push_back(formats::light_direction(first_tilt_deg + 360.0 * k / count, slant_deg));
  return lights;
}

Surface sphere_surface(cv::Size size, double radius, int channels) {
  Surface s{cv::Mat(size, CV_32FC3), cv::Mat(size, CV_32FC(channels))};
  const double cx = (size.width - 1) / 2.0, cy = (size.height - 1) / 2.0;
  for (int r = 0; r < size.height; ++r) {
    for (int c = 0; c < size.width; ++c) {
      const double x = (c - cx) / radius, y = (cy - r) / radius;  // y up
      const double d2 = x * x + y * y;
      cv::Vec3f n(0, 0, 1);
      if (d2 < 1)
        n = cv::Vec3f(static_cast<float>(x), static_cast<float>(y),
                      static_cast<float>(std::sqrt(1 - d2)));
      s.normal.at<cv::Vec3f>(r, c) = n;
      const double u = static_cast<double>(c) / size.width,
                   v = static_cast<double>(r) / size.height;
      float* a = s.albedo.ptr<float>(r) + c * channels;
      a[0] = static_cast<float>(0.35 + 0.3 * u);
      if (channels == 3) {
        a[1] = static_cast<float>(0.6 - 0.25 * v);
        a[2] = static_cast<float>(0.3 + 0.2 * u * v);
      }
    }
  }
  return s;
}

std::vector<cv::Vec3d> dome_lights(int count, double max_slant_deg) {
  const double lowest = std::cos(max_slant_deg * std::numbers::pi / 180);
  const double golden = std::numbers::pi * (3 - std::sqrt(5.0));
  std::vector<cv::Vec3d> lights;
  for (int k = 0; k < count; ++k) {
    const double z = 1 - (1 - lowest) * (k + 0.5) / count;
    const double r = std::sqrt(1 - z * z), phi = golden * k;
    lights.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
  }
  return lights;
}

Surface bumpy_surface(cv::Size size, double amplitude, double period, int channels,
                      cv::Mat* height) {
  Surface s = sphere_surface(size, 1, channels);  // for the albedo; normals below
  if (height) height->create(size, CV_32F);
  const double w = 2 * std::numbers::pi / period;
  for (int r = 0; r < size.height; ++r) {
    for (int c = 0; c < size.width; ++c) {
      const double x = c, y = size.height - 1 - r;  // y up
      const double p = amplitude * w * std::cos(w * x) * std::sin(w * y);
      const double q = amplitude * w * std::sin(w * x) * std::cos(w * y);
      const double norm = std::sqrt(p * p + q * q + 1);
      s.normal.at<cv::Vec3f>(r, c) =
          cv::Vec3f(static_cast<float>(-p / norm), static_cast<float>(-q / norm),
                    static_cast<float>(1 / norm));
      if (height)
        height->at<float>(r, c) = static_cast<float>(amplitude * std::sin(w * x) * std::sin(w * y));
    }
  }
  return s;
}

cv::Mat height_cast_shadow(const cv::Mat& height, const cv::Vec3d& light) {
  cv::Mat mask(height.size(), CV_8U, cv::Scalar(0));
  const cv::Vec3d l = light / cv::norm(light);
  const double along = std::hypot(l[0], l[1]);
  if (along < 1e-9) return mask;
  double top = 0;
  cv::minMaxLoc(height, nullptr, &top);
  const double dx = l[0] / along, dy = l[1] / along, rise = l[2] / along;  // per pixel step
  for (int r = 0; r < height.rows; ++r) {
    for (int c = 0; c < height.cols; ++c) {
      const double z0 = height.at<float>(r, c);
      for (double s = 0.5;; s += 0.5) {
        const double z = z0 + rise * s;
        if (z > top) break;
        const int cc = static_cast<int>(std::lround(c + dx * s));
        const int rr = static_cast<int>(std::lround(r - dy * s));  // y up
        if (cc < 0 || rr < 0 || cc >= height.cols || rr >= height.rows) break;
        if (height.at<float>(rr, cc) > z + 0.05) {
          mask.at<std::uint8_t>(r, c) = 255;
          break;
        }
      }
    }
  }
  return mask;
}

Surface dome_surface(cv::Size size, double radius, int channels) {
  // Same geometry as the sphere: its upper half is the dome.
  return sphere_surface(size, radius, channels);
}

cv::Mat dome_cast_shadow(cv::Size size, double radius, const cv::Vec3d& light) {
  cv::Mat mask(size, CV_8U, cv::Scalar(0));
  const cv::Vec3d l = light / cv::norm(light);
  const double cx = (size.width - 1) / 2.0, cy = (size.height - 1) / 2.0;
  for (int r = 0; r < size.height; ++r) {
    for (int c = 0; c < size.width; ++c) {
      const cv::Vec3d o((c - cx) / radius, (cy - r) / radius, 0);  // plane point, sphere units
      if (o.dot(o) < 1) continue;                                  // on the dome itself
      // o + s l hits the unit sphere for some s > 0 when b^2 >= c and b < 0.
      const double b = o.dot(l), cterm = o.dot(o) - 1;
      if (b < 0 && b * b >= cterm) mask.at<std::uint8_t>(r, c) = 255;
    }
  }
  return mask;
}

formats::Scan render_scan(const Surface& surface, const std::vector<cv::Vec3d>& lights, int depth,
                          double noise, std::uint64_t seed, const std::vector<cv::Mat>& shadows,
                          Specular specular) {
  formats::Scan scan;
  const int channels = surface.albedo.channels();
  const double full = depth == CV_8U ? 255 : depth == CV_16U ? 65535 : 1;
  std::mt19937_64 random(seed);
  std::normal_distribution<double> gaussian(0, noise);
  auto& d = scan.description;
  for (std::size_t k = 0; k < lights.size(); ++k) {
    const cv::Vec3d l = lights[k] / cv::norm(lights[k]);
    d.lights.push_back({"led" + std::to_string(k) + ".png", l, {1, 1, 1}, false, std::nullopt});
    cv::Mat linear(surface.normal.size(), CV_32FC(channels));
    for (int r = 0; r < linear.rows; ++r) {
      for (int c = 0; c < linear.cols; ++c) {
        const cv::Vec3f n = surface.normal.at<cv::Vec3f>(r, c);
        const bool blocked =
            k < shadows.size() && !shadows[k].empty() && shadows[k].at<std::uint8_t>(r, c);
        const double shade = blocked ? 0.0 : std::max(0.0, n[0] * l[0] + n[1] * l[1] + n[2] * l[2]);
        double gloss = 0;
        if (specular.strength > 0 && shade > 0) {
          const cv::Vec3d h = (l + cv::Vec3d(0, 0, 1)) / cv::norm(l + cv::Vec3d(0, 0, 1));
          gloss =
              specular.strength *
              std::pow(std::max(0.0, n[0] * h[0] + n[1] * h[1] + n[2] * h[2]), specular.exponent);
        }
        for (int ch = 0; ch < channels; ++ch) {
          double value = surface.albedo.ptr<float>(r)[c * channels + ch] * shade + gloss;
          if (noise > 0) value += gaussian(random);
          linear.ptr<float>(r)[c * channels + ch] = static_cast<float>(value * full);
        }
      }
    }
    cv::Mat frame;
    linear.convertTo(frame, CV_MAKETYPE(depth, channels));  // rounds and saturates for integers
    scan.frames.push_back(frame);
  }
  d.sample_id = "synthetic";
  d.white_level = full;
  scan.white_level = full;
  scan.ground_truth_normal = surface.normal.clone();
  return scan;
}

double predicted_rms_angle(const std::vector<cv::Vec3d>& lights, const cv::Vec3d& n, double rho,
                           double sigma, int channels) {
  cv::Matx33d ltl = cv::Matx33d::zeros();
  for (const auto& light : lights) {
    const cv::Vec3d l = light / cv::norm(light);
    ltl += l * l.t();
  }
  const cv::Matx33d projector = cv::Matx33d::eye() - n * n.t();
  return sigma / (std::sqrt(static_cast<double>(channels)) * rho) *
         std::sqrt(cv::trace(projector * ltl.inv() * projector));
}

cv::Mat naive_rule_normals(const formats::Scan& scan) {
  const int lights = static_cast<int>(scan.frames.size());
  const int channels = scan.channels();
  const cv::Size size = scan.size();
  cv::Mat normals(size, CV_32FC3, cv::Scalar(0, 0, 0));
  std::vector<cv::Mat> frames;
  cv::Mat dark;
  if (!scan.dark.empty())
    scan.dark.convertTo(dark, CV_MAKETYPE(CV_32F, channels), 1.0 / scan.white_level);
  for (const auto& f : scan.frames) {
    cv::Mat linear;
    f.convertTo(linear, CV_MAKETYPE(CV_32F, channels), 1.0 / scan.white_level);
    if (!dark.empty()) linear -= dark;
    frames.push_back(linear);
  }
  std::vector<std::pair<double, int>> values(static_cast<std::size_t>(lights));
  const auto& d = scan.description.lights;
  for (int r = 0; r < size.height; ++r) {
    for (int c = 0; c < size.width; ++c) {
      for (int k = 0; k < lights; ++k) {
        const float* m = frames[k].ptr<float>(r) + c * channels;
        double sum = 0;
        for (int ch = 0; ch < channels; ++ch)
          sum += m[ch];
        values[k] = {sum / channels, k};
      }
      std::sort(values.begin(), values.end());
      cv::Matx33d a = cv::Matx33d::zeros();
      cv::Vec3d b(0, 0, 0);
      for (int j = lights / 4; j < lights - lights / 6; ++j) {
        const cv::Vec3d l = d[values[j].second].direction;
        a += l * l.t();
        b += l * values[j].first;
      }
      cv::Vec3d t;
      if (!cv::solve(a, b, t, cv::DECOMP_CHOLESKY) || !(t[2] > 0)) continue;
      t /= cv::norm(t);
      normals.at<cv::Vec3f>(r, c) = cv::Vec3f(t);
    }
  }
  return normals;
}

double mean_angular_error_deg(const cv::Mat& a, const cv::Mat& b, const cv::Mat& select) {
  double sum = 0;
  long count = 0;
  for (int r = 0; r < a.rows; ++r) {
    for (int c = 0; c < a.cols; ++c) {
      if (!select.empty() && select.at<std::uint8_t>(r, c) == 0) continue;
      const cv::Vec3d u = a.at<cv::Vec3f>(r, c), v = b.at<cv::Vec3f>(r, c);
      const double cosine = u.dot(v) / (cv::norm(u) * cv::norm(v));
      sum += std::acos(std::clamp(cosine, -1.0, 1.0));
      ++count;
    }
  }
  return count ? sum / count * 180 / std::numbers::pi : 0;
}

}  // namespace psrig::test
