#include "psrig/sim/card_target.h"

namespace psrig::sim {

Swatch white_card(cv::Size size, double pixel_size_mm) {
  Swatch card;
  card.pixel_size_mm = pixel_size_mm;
  card.height_mm = cv::Mat::zeros(size, CV_32F);
  card.normal = cv::Mat(size, CV_32FC3, cv::Scalar(0, 0, 1));
  card.albedo = cv::Mat(size, CV_32FC3, cv::Scalar::all(kWhiteCardAlbedo));
  return card;
}

}  // namespace psrig::sim
