#include "psrig/preview/reference_render.h"

#include <cmath>

namespace psrig::preview {
namespace {

int wrap(int index, int size) {
  return ((index % size) + size) % size;
}

cv::Vec4f albedo_texel(const cv::Mat& level, int x, int y) {
  const auto& coded = level.at<cv::Vec4b>(wrap(y, level.rows), wrap(x, level.cols));
  return {srgb_decode(coded[0] / 255.0f), srgb_decode(coded[1] / 255.0f),
          srgb_decode(coded[2] / 255.0f), coded[3] / 255.0f};
}

cv::Vec4f normal_texel(const cv::Mat& level, int x, int y) {
  const auto& half = level.at<cv::Vec<cv::float16_t, 4>>(wrap(y, level.rows), wrap(x, level.cols));
  return {float(half[0]), float(half[1]), float(half[2]), float(half[3])};
}

template <class Texel>
cv::Vec4f bilinear(const cv::Mat& level, float u, float v, Texel texel) {
  const float s = u * static_cast<float>(level.cols) - 0.5f;
  const float t = v * static_cast<float>(level.rows) - 0.5f;
  const float s0 = std::floor(s), t0 = std::floor(t);
  const float fs = s - s0, ft = t - t0;
  const int x = static_cast<int>(s0), y = static_cast<int>(t0);
  return (1 - fs) * (1 - ft) * texel(level, x, y) + fs * (1 - ft) * texel(level, x + 1, y) +
         (1 - fs) * ft * texel(level, x, y + 1) + fs * ft * texel(level, x + 1, y + 1);
}

}  // namespace

SurfaceSample sample_level(const TextureLevels& levels, int level, float u, float v) {
  const auto index = static_cast<std::size_t>(level);
  const cv::Vec4f albedo = bilinear(levels.albedo_alpha[index], u, v, albedo_texel);
  const cv::Vec4f normal = bilinear(levels.normal_gloss[index], u, v, normal_texel);
  return {
      {albedo[0], albedo[1], albedo[2]}, albedo[3], {normal[0], normal[1], normal[2]}, normal[3]};
}

std::expected<cv::Mat, std::string> render_flat_reference(const TextureLevels& levels, int level,
                                                          cv::Size2d swatch_extent,
                                                          const SceneView& view,
                                                          const ShadingParams& params,
                                                          cv::Vec3f background) {
  if (view.kind != ViewKind::flat || view.model_yaw_deg != 0 || view.model_pitch_deg != 0 ||
      view.camera_yaw_deg != 0 || view.camera_pitch_deg != 0 || view.margin != 0 || view.zoom != 1)
    return std::unexpected("the reference covers the flat view, unrotated, unzoomed, no margin");
  if (level < 0 || static_cast<std::size_t>(level) >= levels.albedo_alpha.size())
    return std::unexpected("no texture level " + std::to_string(level));
  const cv::Size size = levels.albedo_alpha[static_cast<std::size_t>(level)].size();
  const FrameSetup setup = frame_setup(swatch_extent, view, size);
  const Eigen::Vector3f eye = setup.eye.head<3>();
  cv::Mat frame(size, CV_8UC3);
  for (int row = 0; row < size.height; ++row)
    for (int col = 0; col < size.width; ++col) {
      const float u = (static_cast<float>(col) + 0.5f) / static_cast<float>(size.width);
      const float v = 1.0f - (static_cast<float>(row) + 0.5f) / static_cast<float>(size.height);
      // The flat patch's tangent frame is the world's: tangent space = world.
      const Eigen::Vector3f point((u - 0.5f) * static_cast<float>(setup.patch_extent.width),
                                  (v - 0.5f) * static_cast<float>(setup.patch_extent.height), 0);
      const Eigen::Vector3f to_light = setup.light.head<3>() - setup.light[3] * point;
      const float attenuation = setup.light[3] > 0
                                    ? setup.light_reference_distance *
                                          setup.light_reference_distance / to_light.squaredNorm()
                                    : 1.0f;
      const SurfaceSample sample = sample_level(levels, level, u, v);
      const cv::Vec4f lit = shade(sample, {to_light.x(), to_light.y(), to_light.z()},
                                  {eye.x(), eye.y(), eye.z()}, attenuation, params);
      auto& out = frame.at<cv::Vec3b>(row, col);
      for (int c = 0; c < 3; ++c) {
        const float blended = lit[3] * lit[c] + (1 - lit[3]) * background[c];
        out[2 - c] = srgb8(blended);
      }
    }
  return frame;
}

}  // namespace psrig::preview
