#include "psrig/formats/light_matrix.h"

#include <cmath>
#include <limits>
#include <numbers>

#include <Eigen/Dense>

namespace psrig::formats {

cv::Vec3d light_direction(double tilt_deg, double slant_deg) {
  const double tilt = tilt_deg * std::numbers::pi / 180, slant = slant_deg * std::numbers::pi / 180;
  return {std::cos(tilt) * std::sin(slant), std::sin(tilt) * std::sin(slant), std::cos(slant)};
}

LightMatrix make_light_matrix(const std::vector<cv::Vec3d>& directions) {
  LightMatrix result;
  const int n = static_cast<int>(directions.size());
  Eigen::MatrixXd l(n, 3);
  for (int k = 0; k < n; ++k) {
    const cv::Vec3d unit = directions[k] / cv::norm(directions[k]);
    result.directions.push_back(unit);
    l.row(k) << unit[0], unit[1], unit[2];
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(l);
  const auto& singular = svd.singularValues();
  const double smallest = singular.size() == 3 ? singular(2) : 0.0;
  result.condition_number =
      smallest > 0 ? singular(0) / smallest : std::numeric_limits<double>::infinity();
  return result;
}

LightMatrix make_light_matrix(const ScanDescription& description) {
  std::vector<cv::Vec3d> directions;
  for (const auto& light : description.lights)
    directions.push_back(light.direction);
  return make_light_matrix(directions);
}

}  // namespace psrig::formats
