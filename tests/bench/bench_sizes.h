#pragma once
// The benchmarks' 12 MP: a 4056 x 3040 sensor (the Raspberry Pi HQ
// camera's IMX477), the largest the rig is built for.

#include <opencv2/core/types.hpp>

namespace psrig::bench {

inline constexpr int kWidth = 4056;
inline constexpr int kHeight = 3040;
inline const cv::Size k12MP(kWidth, kHeight);

}  // namespace psrig::bench
