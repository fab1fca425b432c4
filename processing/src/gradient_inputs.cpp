#include "gradient_inputs.h"

#include <string>
#include <utility>

namespace psrig::processing {

Result<cv::Size> check_gradient_inputs(const cv::Mat& p, const cv::Mat& q) {
  using Named = std::pair<const cv::Mat*, const char*>;
  for (const auto& [mat, name] : {Named{&p, "p"}, Named{&q, "q"}}) {
    if (mat->empty())
      return std::unexpected(bad_input({}, {}, std::string("integration: ") + name + " is empty"));
    if (mat->dims != 2 || mat->type() != CV_32FC1)
      return std::unexpected(
          bad_input({}, {},
                    std::string("integration: ") + name +
                        " must be a 2-D one-channel float image (CV_32FC1), got " +
                        cv::typeToString(mat->type())));
  }
  if (p.size() != q.size())
    return std::unexpected(bad_input({}, {},
                                     "integration: p is " + std::to_string(p.cols) + "x" +
                                         std::to_string(p.rows) + " but q is " +
                                         std::to_string(q.cols) + "x" + std::to_string(q.rows)));
  return p.size();
}

}  // namespace psrig::processing
