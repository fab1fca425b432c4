#include "psrig/calibration/scale.h"

#include <cmath>
#include <numbers>
#include <utility>
#include <vector>

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/imgproc.hpp>

namespace psrig::calibration {

namespace {

cv::Ptr<cv::aruco::CharucoBoard> make_board(const CharucoSpec& spec) {
  return cv::aruco::CharucoBoard::create(
      spec.squares_x, spec.squares_y, static_cast<float>(spec.square_mm),
      static_cast<float>(spec.marker_mm),
      cv::aruco::getPredefinedDictionary(dictionary_id(spec.dictionary)));
}

}  // namespace

int dictionary_id(const std::string& name) {
  static const std::pair<const char*, int> names[] = {
      {"DICT_4X4_50", cv::aruco::DICT_4X4_50},
      {"DICT_4X4_100", cv::aruco::DICT_4X4_100},
      {"DICT_4X4_250", cv::aruco::DICT_4X4_250},
      {"DICT_4X4_1000", cv::aruco::DICT_4X4_1000},
      {"DICT_5X5_50", cv::aruco::DICT_5X5_50},
      {"DICT_5X5_100", cv::aruco::DICT_5X5_100},
      {"DICT_5X5_250", cv::aruco::DICT_5X5_250},
      {"DICT_5X5_1000", cv::aruco::DICT_5X5_1000},
      {"DICT_6X6_50", cv::aruco::DICT_6X6_50},
      {"DICT_6X6_100", cv::aruco::DICT_6X6_100},
      {"DICT_6X6_250", cv::aruco::DICT_6X6_250},
      {"DICT_6X6_1000", cv::aruco::DICT_6X6_1000},
      {"DICT_7X7_50", cv::aruco::DICT_7X7_50},
      {"DICT_7X7_100", cv::aruco::DICT_7X7_100},
      {"DICT_7X7_250", cv::aruco::DICT_7X7_250},
      {"DICT_7X7_1000", cv::aruco::DICT_7X7_1000},
      {"DICT_ARUCO_ORIGINAL", cv::aruco::DICT_ARUCO_ORIGINAL}};
  for (const auto& [n, id] : names)
    if (name == n) return id;
  return -1;
}

cv::Mat draw_charuco(const CharucoSpec& spec, double px_per_mm) {
  const auto board = make_board(spec);
  const cv::Size size(static_cast<int>(std::lround(spec.squares_x * spec.square_mm * px_per_mm)),
                      static_cast<int>(std::lround(spec.squares_y * spec.square_mm * px_per_mm)));
  cv::Mat image;
  board->draw(size, image, 0, 1);
  return image;
}

Result<ScaleEstimate> measure_scale(const cv::Mat& image, const CharucoSpec& spec,
                                    const std::filesystem::path& source) {
  const auto board = make_board(spec);
  // 8 bits for the marker detector: the image's 0.5th to 99.5th percentile
  // stretched over the range.
  cv::Mat grey;
  if (image.channels() == 3)
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  else
    grey = image;
  grey.convertTo(grey, CV_32F);
  double lo = 0, hi = 0;
  cv::minMaxLoc(grey, &lo, &hi);
  cv::Mat bytes;
  grey.convertTo(bytes, CV_8U, hi > lo ? 255.0 / (hi - lo) : 1.0,
                 hi > lo ? -255.0 * lo / (hi - lo) : 0.0);

  std::vector<std::vector<cv::Point2f>> marker_corners;
  std::vector<int> marker_ids;
  cv::aruco::detectMarkers(bytes, board->dictionary, marker_corners, marker_ids);
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
  if (!marker_ids.empty())
    cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, bytes, board, corners, ids);
  if (corners.size() < 6)
    return std::unexpected(bad_input(
        source, "",
        "shows no ChArUco board (" + std::to_string(marker_ids.size()) + " markers, " +
            std::to_string(corners.size()) +
            " corners found): lay the printed board flat under the camera, in focus and "
            "evenly lit, and give its --squares, --square-mm, --marker-mm and --dictionary"));

  // x = a X - b Y + tx, y = b X + a Y + ty over the corners (board mm to
  // image px), least squares; the scale is |(a, b)|. The board's y axis
  // may run either way in the image: the better of both fits.
  const auto& positions = board->chessboardCorners;
  const int n = static_cast<int>(corners.size());
  struct Fit {
    cv::Mat p, covariance;
    double sse = 0;
  };
  const auto fit = [&](double flip) {
    cv::Mat A(2 * n, 4, CV_64F), y(2 * n, 1, CV_64F);
    for (int i = 0; i < n; ++i) {
      const cv::Point3f& P = positions[static_cast<std::size_t>(ids[i])];
      const double X = P.x, Y = flip * P.y;
      A.at<double>(2 * i, 0) = X;
      A.at<double>(2 * i, 1) = -Y;
      A.at<double>(2 * i, 2) = 1;
      A.at<double>(2 * i, 3) = 0;
      A.at<double>(2 * i + 1, 0) = Y;
      A.at<double>(2 * i + 1, 1) = X;
      A.at<double>(2 * i + 1, 2) = 0;
      A.at<double>(2 * i + 1, 3) = 1;
      y.at<double>(2 * i) = corners[i].x;
      y.at<double>(2 * i + 1) = corners[i].y;
    }
    Fit f;
    cv::solve(A, y, f.p, cv::DECOMP_SVD);
    const cv::Mat residual = A * f.p - y;
    f.sse = residual.dot(residual);
    const double dof = std::max(1, 2 * n - 4);
    f.covariance = (A.t() * A).inv(cv::DECOMP_SVD) * (f.sse / dof);
    return f;
  };
  Fit best = fit(1.0);
  if (Fit other = fit(-1.0); other.sse < best.sse) best = other;
  const cv::Mat& p = best.p;
  const cv::Mat& covariance = best.covariance;
  const double a = p.at<double>(0), b = p.at<double>(1);
  const double s = std::hypot(a, b);  // px per mm
  // var(s) through its gradient (a/s, b/s).
  const double var_s = (a * a * covariance.at<double>(0, 0) + b * b * covariance.at<double>(1, 1) +
                        2 * a * b * covariance.at<double>(0, 1)) /
                       (s * s);
  ScaleEstimate e;
  e.pixel_size_mm = 1.0 / s;
  e.uncertainty_mm = std::sqrt(std::max(0.0, var_s)) / (s * s);
  e.rotation_deg = std::atan2(b, a) * 180.0 / std::numbers::pi;
  e.fit_rms_px = std::sqrt(best.sse / n);
  e.corners = n;
  e.markers = static_cast<int>(marker_ids.size());
  return e;
}

}  // namespace psrig::calibration
