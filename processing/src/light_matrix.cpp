#include "psrig/processing/light_matrix.h"

#include <cmath>
#include <limits>

#include <Eigen/Dense>

namespace psrig::processing {

LightMatrix make_light_matrix(const std::vector<cv::Vec3d>& directions) {
  LightMatrix result;
  const int n = static_cast<int>(directions.size());
  Eigen::MatrixXd l(n, 3);
  for (int k = 0; k < n; ++k) {
    const cv::Vec3d unit = directions[k] / cv::norm(directions[k]);
    result.directions.push_back(unit);
    l.row(k) << unit[0], unit[1], unit[2];
  }

  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(l, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const auto& singular = svd.singularValues();
  const double smallest = singular.size() == 3 ? singular(2) : 0.0;
  result.condition_number =
      smallest > 0 ? singular(0) / smallest : std::numeric_limits<double>::infinity();

  const Eigen::Matrix3d normal = l.transpose() * l;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      result.normal_matrix(r, c) = normal(r, c);

  if (std::isfinite(result.condition_number)) {
    const Eigen::MatrixXd pinv = normal.inverse() * l.transpose();  // 3 x n
    for (int k = 0; k < n; ++k)
      result.pseudo_inverse_columns.emplace_back(pinv(0, k), pinv(1, k), pinv(2, k));
  }
  return result;
}

}  // namespace psrig::processing
