#include "lattice_sampling.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace psrig::analysis::inference {

float sample(const cv::Mat& map, cv::Point2d p) {
  if (!(p.x >= 0 && p.y >= 0 && p.x <= map.cols - 1 && p.y <= map.rows - 1))
    return std::numeric_limits<float>::quiet_NaN();
  const int x0 = std::min(static_cast<int>(p.x), map.cols - 2);
  const int y0 = std::min(static_cast<int>(p.y), map.rows - 2);
  const auto fx = static_cast<float>(p.x - x0);
  const auto fy = static_cast<float>(p.y - y0);
  const float* r0 = map.ptr<float>(y0);
  const float* r1 = map.ptr<float>(y0 + 1);
  const float a = r0[x0] * (1 - fx) + r0[x0 + 1] * fx;
  const float b = r1[x0] * (1 - fx) + r1[x0 + 1] * fx;
  return a * (1 - fy) + b * fy;
}

bool normalise(cv::Mat& face) {
  if (!cv::checkRange(face)) return false;
  face -= cv::mean(face)[0];
  const double n = cv::norm(face);
  if (!(n > 1e-12)) return false;
  face /= n;
  return true;
}

cv::Point2d RepeatFrame::coordinates(cv::Point2d p) const {
  const cv::Point2d d = p - origin;
  const double det = cross(u, w);
  return {cross(d, w) / det, cross(u, d) / det};
}

cv::Mat fold(const cv::Mat& height, cv::Rect window, const RepeatFrame& frame, Split split,
             int n) {
  const int cols = split.wales * n, rows = split.courses * n;
  // The copies of the repeat that reach into the window.
  double a0 = 1e9, a1 = -1e9, b0 = 1e9, b1 = -1e9;
  for (const cv::Point2d corner : {cv::Point2d(window.tl()), cv::Point2d(window.br()),
                                   cv::Point2d(window.x, window.y + window.height),
                                   cv::Point2d(window.x + window.width, window.y)}) {
    const cv::Point2d st = frame.coordinates(corner);
    a0 = std::min(a0, st.x);
    a1 = std::max(a1, st.x);
    b0 = std::min(b0, st.y);
    b1 = std::max(b1, st.y);
  }
  const cv::Mat inside = height(window);
  const cv::Point2d offset(window.x, window.y);
  cv::Mat mean(rows, cols, CV_32F);
  double total = 0, samples = 0;
  std::vector<cv::Point> empty;
  for (int r = 0; r < rows; ++r) {
    const double t = 1 - (r + 0.5) / rows;
    for (int c = 0; c < cols; ++c) {
      const double s = (c + 0.5) / cols;
      double sum = 0;
      int copies = 0;
      for (int a = static_cast<int>(std::floor(a0)) - 1; a <= static_cast<int>(std::ceil(a1)); ++a)
        for (int b = static_cast<int>(std::floor(b0)) - 1; b <= static_cast<int>(std::ceil(b1));
             ++b) {
          const float value = sample(inside, frame.at(s + a, t + b) - offset);
          if (std::isnan(value)) continue;
          sum += value;
          ++copies;
        }
      mean.at<float>(r, c) = copies > 0 ? static_cast<float>(sum / copies) : 0.0f;
      if (copies == 0) empty.emplace_back(c, r);
      total += sum;
      samples += copies;
    }
  }
  for (const cv::Point p : empty)
    mean.at<float>(p) = static_cast<float>(total / std::max(1.0, samples));
  return mean;
}

StitchBlock inner_stitches(const StitchLattice& lattice, cv::Size size) {
  const auto inside = [&](cv::Point2d p) {
    return p.x >= 0 && p.y >= 0 && p.x <= size.width - 1 && p.y <= size.height - 1;
  };
  const double det = cross(lattice.next_wale_px, lattice.next_course_px);
  double i0 = 1e9, i1 = -1e9, j0 = 1e9, j1 = -1e9;
  for (const cv::Point2d corner : {cv::Point2d(0, 0), cv::Point2d(size.width - 1, 0),
                                   cv::Point2d(0, size.height - 1),
                                   cv::Point2d(size.width - 1, size.height - 1)}) {
    const cv::Point2d d = corner - lattice.origin_px;
    const double i = cross(d, lattice.next_course_px) / det;
    const double j = cross(lattice.next_wale_px, d) / det;
    i0 = std::min(i0, i);
    i1 = std::max(i1, i);
    j0 = std::min(j0, j);
    j1 = std::max(j1, j);
  }
  cv::Rect box(static_cast<int>(std::floor(i0)), static_cast<int>(std::floor(j0)), 0, 0);
  box.width = static_cast<int>(std::ceil(i1)) - box.x;
  box.height = static_cast<int>(std::ceil(j1)) - box.y;
  const auto face_inside = [&](int i, int j) {
    return inside(lattice.corner(i, j)) && inside(lattice.corner(i + 1, j)) &&
           inside(lattice.corner(i, j + 1)) && inside(lattice.corner(i + 1, j + 1));
  };
  // Shrink the side with the most faces outside until none is.
  while (box.width > 0 && box.height > 0) {
    int left = 0, right = 0, bottom = 0, top = 0;
    for (int j = box.y; j < box.y + box.height; ++j) {
      left += !face_inside(box.x, j);
      right += !face_inside(box.x + box.width - 1, j);
    }
    for (int i = box.x; i < box.x + box.width; ++i) {
      bottom += !face_inside(i, box.y);
      top += !face_inside(i, box.y + box.height - 1);
    }
    const int worst = std::max({left, right, bottom, top});
    if (worst == 0) break;
    if (worst == left) {
      ++box.x;
      --box.width;
    } else if (worst == right) {
      --box.width;
    } else if (worst == bottom) {
      ++box.y;
      --box.height;
    } else {
      --box.height;
    }
  }
  StitchBlock block;
  block.columns = std::max(0, box.width);
  block.rows = std::max(0, box.height);
  block.first = box.tl();
  block.lattice = {lattice.corner(box.x, box.y), lattice.next_wale_px, lattice.next_course_px};
  return block;
}

std::vector<cv::Mat> faces_of(const cv::Mat& height, const StitchBlock& block, int n) {
  std::vector<cv::Mat> faces;
  faces.reserve(static_cast<std::size_t>(block.columns * block.rows));
  for (int row = 0; row < block.rows; ++row)
    for (int column = 0; column < block.columns; ++column) {
      cv::Mat face(n, n, CV_32F);
      for (int r = 0; r < n; ++r)
        for (int c = 0; c < n; ++c)
          face.at<float>(r, c) = sample(
              height, block.lattice.corner(column + (c + 0.5) / n, row + 1 - (r + 0.5) / n));
      faces.push_back(normalise(face) ? face : cv::Mat());
    }
  return faces;
}

std::vector<Eigen::Vector3f> colours_of(const cv::Mat& albedo, const StitchBlock& block, int n) {
  std::vector<cv::Mat> channels;
  cv::split(albedo, channels);
  std::vector<Eigen::Vector3f> colours;
  colours.reserve(static_cast<std::size_t>(block.columns * block.rows));
  // Where the stitch's own yarn shows: the middle half across, and up the
  // face the half a quarter below its middle (the V's legs and the purl
  // bump sit low in the face; above them the next course's loop comes
  // through, maybe of another colour). Measured on the cloth model's
  // two-colour stripes: this window gives each stitch its own yarn's colour.
  const int from = n / 4, to = n - n / 4;
  const int top = 3 * n / 8, bottom = 7 * n / 8;
  for (int row = 0; row < block.rows; ++row)
    for (int column = 0; column < block.columns; ++column) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      int count = 0;
      for (int r = top; r < bottom; ++r)
        for (int c = from; c < to; ++c) {
          const cv::Point2d p =
              block.lattice.corner(column + (c + 0.5) / n, row + 1 - (r + 0.5) / n);
          Eigen::Vector3d bgr;
          for (int ch = 0; ch < 3; ++ch)
            bgr[ch] = sample(channels[channels.size() == 1 ? 0 : static_cast<std::size_t>(ch)], p);
          if (!bgr.allFinite()) continue;
          sum += bgr;
          ++count;
        }
      sum /= std::max(1, count);
      colours.emplace_back(static_cast<float>(sum[2]), static_cast<float>(sum[1]),
                           static_cast<float>(sum[0]));
    }
  return colours;
}

std::pair<double, double> spacing(const StitchLattice& lattice) {
  const double area = std::abs(cross(lattice.next_wale_px, lattice.next_course_px));
  return {area / norm(lattice.next_course_px), area / norm(lattice.next_wale_px)};
}

}  // namespace psrig::analysis::inference
