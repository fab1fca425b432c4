#include "psrig/preview/repeat_maps.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "psrig/preview/repeat_texture.h"

namespace psrig::preview {

RepeatMaps repeat_maps(const cv::Mat& texels, const cv::Vec3f& flat_shading,
                       const cv::Size2f& repeat_mm) {
  cv::Mat premultiplied;  // top row first, as the maps are
  cv::flip(texels, premultiplied, 0);
  const cv::Scalar mean = cv::mean(premultiplied);
  const double coverage = std::max(mean[3], 1e-3);
  // Under a texel of little coverage its colour is noise: the mean's.
  constexpr float kLeastCoverage = 0.05f;
  RepeatMaps out;
  SwatchMaps& maps = out.maps;
  maps.albedo.create(premultiplied.size(), CV_32FC3);
  maps.alpha.create(premultiplied.size(), CV_32FC1);
  float brightest = 0;
  for (int y = 0; y < premultiplied.rows; ++y)
    for (int x = 0; x < premultiplied.cols; ++x) {
      const cv::Vec4f& texel = premultiplied.at<cv::Vec4f>(y, x);
      cv::Vec3f& albedo = maps.albedo.at<cv::Vec3f>(y, x);
      for (int c = 0; c < 3; ++c) {
        const double colour = texel[3] > kLeastCoverage ? texel[c] / texel[3] : mean[c] / coverage;
        albedo[c] = static_cast<float>(colour / std::max(flat_shading[c], 1e-4f));
        brightest = std::max(brightest, albedo[c]);
      }
      maps.alpha.at<float>(y, x) = std::clamp(texel[3], 0.0f, 1.0f);
    }
  out.gain = std::max(brightest, 1.0f);
  maps.albedo /= out.gain;
  // Square pixels: the width kept, the height resampled to the repeat's.
  const int height = std::max(
      1, static_cast<int>(std::lround(maps.albedo.cols * repeat_mm.height / repeat_mm.width)));
  if (height != maps.albedo.rows) {
    cv::resize(maps.albedo, maps.albedo, {maps.albedo.cols, height}, 0, 0, cv::INTER_AREA);
    cv::resize(maps.alpha, maps.alpha, {maps.alpha.cols, height}, 0, 0, cv::INTER_AREA);
  }
  maps.pixel_size_mm = repeat_mm.width / static_cast<float>(maps.albedo.cols);
  maps.normal = cv::Mat(maps.albedo.size(), CV_32FC3, cv::Scalar(0, 0, 1));
  maps.gloss = cv::Mat::zeros(maps.albedo.size(), CV_32FC1);
  maps.sample_id = "chart repeat";
  return out;
}

}  // namespace psrig::preview
