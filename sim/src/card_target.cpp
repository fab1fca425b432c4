#include "psrig/sim/card_target.h"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "psrig/calibration/scale.h"
#include "target_sampling.h"

namespace psrig::sim {

Swatch white_card(cv::Size size, double pixel_size_mm, float albedo) {
  Swatch card;
  card.pixel_size_mm = pixel_size_mm;
  card.height_mm = cv::Mat::zeros(size, CV_32F);
  card.normal = cv::Mat(size, CV_32FC3, cv::Scalar(0, 0, 1));
  card.albedo = cv::Mat(size, CV_32FC3, cv::Scalar::all(albedo));
  return card;
}

Swatch charuco_board(cv::Size size, double pixel_size_mm) {
  const double sample_mm = pixel_size_mm / kSamplesPerPixel;
  calibration::CharucoSpec spec;
  spec.squares_x = kBoardSquaresX;
  spec.squares_y = kBoardSquaresY;
  spec.square_mm = kBoardSquareMm;
  spec.marker_mm = kBoardMarkerMm;
  const cv::Mat ink = calibration::draw_charuco(spec, 1.0 / sample_mm);
  const cv::Size printed = ink.size();
  // White paper with the board centred on it, then into the sensor's pixels.
  const cv::Size fine(size.width * kSamplesPerPixel, size.height * kSamplesPerPixel);
  cv::Mat paper(fine, CV_8U, cv::Scalar(255));
  const cv::Point offset((fine.width - printed.width) / 2, (fine.height - printed.height) / 2);
  const cv::Rect placed = cv::Rect(offset, printed) & cv::Rect(cv::Point(), fine);
  ink(cv::Rect(placed.tl() - offset, placed.size())).copyTo(paper(placed));
  cv::Mat reflectance;
  paper.convertTo(reflectance, CV_32F, (kWhiteCardAlbedo - kBoardInkAlbedo) / 255.0,
                  kBoardInkAlbedo);
  cv::resize(reflectance, reflectance, size, 0, 0, cv::INTER_AREA);
  Swatch card = white_card(size, pixel_size_mm);
  cv::merge(std::vector<cv::Mat>{reflectance, reflectance, reflectance}, card.albedo);
  return card;
}

}  // namespace psrig::sim
