#pragma once
// The checks every integrator makes of the gradients it is given.

#include <opencv2/core.hpp>

#include "psrig/base/error.h"

namespace psrig::processing {

// p and q as the integrators take them: non-empty 2-D one-channel float
// images of one size; that size, or bad input saying what is wrong.
[[nodiscard]] Result<cv::Size> check_gradient_inputs(const cv::Mat& p, const cv::Mat& q);

}  // namespace psrig::processing
