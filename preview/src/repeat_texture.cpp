#include "psrig/preview/repeat_texture.h"

#include <algorithm>
#include <cmath>

#include "psrig/cloth/srgb.h"

namespace psrig::preview {

std::optional<RepeatWindow> middle_repeat(const cloth::YarnSurface& surface) {
  if (surface.empty()) return std::nullopt;
  const cloth::StitchMesh& mesh = surface.mesh;
  RepeatWindow window;
  window.columns = surface.repeat_columns;
  window.rows = surface.repeat_rows;
  // Whole repeats from the first face, the middle one (the edges' stitches
  // are not the pattern's).
  const auto middle = [](int faces, int repeat) {
    const int repeats = faces / repeat;
    return std::max(0, (repeats - 1) / 2) * repeat;
  };
  window.first_column = middle(mesh.columns, window.columns);
  window.first_row = middle(mesh.rows, window.rows);
  window.origin = mesh.vertex(window.first_column, window.first_row);
  window.across =
      mesh.vertex(window.first_column + window.columns, window.first_row) - window.origin;
  window.up = mesh.vertex(window.first_column, window.first_row + window.rows) - window.origin;
  if (window.across.cross(window.up).norm() < 1e-9f) return std::nullopt;
  return window;
}

cloth::YarnSet window_yarns(const cloth::YarnSet& yarns, const RepeatWindow& window,
                            float margin_mm) {
  cloth::YarnSet near;
  near.style = yarns.style;
  // (s, t) of a point in the window, and its height over the window's plane.
  Eigen::Matrix3f axes;
  axes << window.across, window.up, window.normal();
  const Eigen::Matrix3f to_window = axes.inverse();
  const float margin_s = margin_mm / window.across.norm();
  const float margin_t = margin_mm / window.up.norm();
  const auto inside = [&](const Eigen::Vector3f& point) {
    const Eigen::Vector3f st = to_window * (point - window.origin);
    return st.x() > -margin_s && st.x() < 1 + margin_s && st.y() > -margin_t &&
           st.y() < 1 + margin_t && std::abs(st.z()) < margin_mm;
  };
  for (const cloth::YarnCurve& curve : yarns.curves) {
    std::size_t k = 0;
    while (k < curve.points.size()) {
      while (k < curve.points.size() && !inside(curve.points[k]))
        ++k;
      const std::size_t first = k;
      while (k < curve.points.size() && inside(curve.points[k]))
        ++k;
      if (k - first < 3) continue;
      cloth::YarnCurve& run = near.curves.emplace_back();
      const auto copy = [&](const auto& from, auto& to) {
        if (from.size() == curve.points.size())
          to.assign(from.begin() + static_cast<std::ptrdiff_t>(first),
                    from.begin() + static_cast<std::ptrdiff_t>(k));
      };
      copy(curve.points, run.points);
      copy(curve.normals, run.normals);
      copy(curve.lift, run.lift);
      copy(curve.colours, run.colours);
    }
  }
  return near;
}

KnitFrame repeat_frame(const KnitFrame& seen, const RepeatWindow& window,
                       const Eigen::Vector3f& toward_eye, float texels_per_mm, float depth_mm) {
  KnitFrame frame = seen;
  // p = origin + s across + t up + w toward_eye: clip (2s - 1, 2t - 1),
  // nearer the eye (w larger) nearer in depth.
  Eigen::Matrix3f axes;
  axes << window.across, window.up, toward_eye;
  const Eigen::Matrix3f to_stw = axes.inverse();
  Eigen::Matrix4f stw = Eigen::Matrix4f::Identity();
  stw.topLeftCorner<3, 3>() = to_stw;
  stw.topRightCorner<3, 1>() = -to_stw * window.origin;
  Eigen::Matrix4f to_clip = Eigen::Matrix4f::Identity();
  to_clip(0, 0) = 2;
  to_clip(0, 3) = -1;
  to_clip(1, 1) = 2;
  to_clip(1, 3) = -1;
  to_clip(2, 2) = -1 / std::max(depth_mm, 1e-3f);
  frame.projection = to_clip * stw;
  frame.view = Eigen::Matrix4f::Identity();
  frame.orthographic = true;
  frame.centre = window.centre();
  // Far enough that every point sees the eye along one direction.
  frame.distance = 1;
  frame.eye = frame.centre + toward_eye * 1e5f;
  frame.focal_px = texels_per_mm;  // clip w is 1
  return frame;
}

cv::Mat repeat_texels(const cv::Mat& over_black, const cv::Mat& over_white) {
  cv::Mat level(over_black.size(), CV_32FC4);
  const int rows = over_black.rows;
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < over_black.cols; ++x) {
      const auto& black = over_black.at<cv::Vec3b>(rows - 1 - y, x);
      const auto& white = over_white.at<cv::Vec3b>(rows - 1 - y, x);
      cv::Vec4f& texel = level.at<cv::Vec4f>(y, x);
      float through = 0;
      for (int c = 0; c < 3; ++c) {
        const float on_black = cloth::srgb_decode(static_cast<float>(black[2 - c]) / 255.0f);
        const float on_white = cloth::srgb_decode(static_cast<float>(white[2 - c]) / 255.0f);
        texel[c] = on_black;
        through += std::clamp(on_white - on_black, 0.0f, 1.0f) / 3;
      }
      texel[3] = 1 - through;
    }
  return level;
}

std::vector<cv::Mat> repeat_levels(const cv::Mat& texels) {
  std::vector<cv::Mat> levels{texels};
  cv::Mat level = texels;
  while (level.cols > 1 || level.rows > 1) {
    const int step_x = level.cols > 1 ? 2 : 1, step_y = level.rows > 1 ? 2 : 1;
    cv::Mat coarser(level.rows / step_y, level.cols / step_x, CV_32FC4);
    for (int y = 0; y < coarser.rows; ++y)
      for (int x = 0; x < coarser.cols; ++x) {
        cv::Vec4f sum = 0;
        for (int dy = 0; dy < step_y; ++dy)
          for (int dx = 0; dx < step_x; ++dx)
            sum += level.at<cv::Vec4f>(y * step_y + dy, x * step_x + dx);
        coarser.at<cv::Vec4f>(y, x) = sum / static_cast<float>(step_x * step_y);
      }
    levels.push_back(coarser);
    level = coarser;
  }
  return levels;
}

AreaTable repeat_area_table(const cv::Mat& level) {
  AreaTable table;
  const cv::Scalar mean = cv::mean(level);
  table.mean = cv::Vec4f(static_cast<float>(mean[0]), static_cast<float>(mean[1]),
                         static_cast<float>(mean[2]), static_cast<float>(mean[3]));
  const int width = level.cols, height = level.rows;
  // Doubles while summing: the table's entries are rounded once, to float.
  cv::Mat sums(2 * height + 1, 2 * width + 1, CV_64FC4, cv::Scalar::all(0));
  for (int y = 1; y <= 2 * height; ++y)
    for (int x = 1; x <= 2 * width; ++x) {
      const cv::Vec4f texel = level.at<cv::Vec4f>((y - 1) % height, (x - 1) % width) - table.mean;
      sums.at<cv::Vec4d>(y, x) = cv::Vec4d(texel[0], texel[1], texel[2], texel[3]) +
                                 sums.at<cv::Vec4d>(y - 1, x) + sums.at<cv::Vec4d>(y, x - 1) -
                                 sums.at<cv::Vec4d>(y - 1, x - 1);
    }
  sums.convertTo(table.sums, CV_32FC4);
  return table;
}

}  // namespace psrig::preview
