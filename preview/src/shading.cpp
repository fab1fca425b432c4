#include "psrig/preview/shading.h"

#include <algorithm>
#include <cmath>

namespace psrig::preview {

cv::Vec4f shade(const SurfaceSample& sample, cv::Vec3f to_light, cv::Vec3f to_eye,
                float attenuation, const ShadingParams& params) {
  const cv::Vec3f light = cv::normalize(to_light);
  const cv::Vec3f eye = cv::normalize(to_eye);
  const float length = std::max(static_cast<float>(cv::norm(sample.normal)), 1e-4f);
  const cv::Vec3f normal = sample.normal / length;
  // Toksvig: the averaged normal's length says how spread the normals were.
  const float toksvig = length / (length + params.shininess * (1.0f - length));
  const float exponent = std::max(toksvig * params.shininess, 1.0f);
  // The macro surface shadows what lies beneath its plane, softly so the
  // light does not pop at the horizon.
  const float horizon = std::clamp(light[2] * 4.0f, 0.0f, 1.0f);
  // The averaged (unnormalised) normal gives the mean Lambert term.
  const float lambert = std::max(sample.normal.dot(light), 0.0f);
  const cv::Vec3f half = cv::normalize(light + eye);
  const float facing = normal.dot(light) > 0.0f ? 1.0f : 0.0f;
  const float highlight = facing * (exponent + 2.0f) / (params.shininess + 2.0f) *
                          std::pow(std::max(normal.dot(half), 0.0f), exponent);
  const float direct = attenuation * horizon;
  cv::Vec4f colour;
  for (int c = 0; c < 3; ++c) {
    const float light_c = params.light_colour[c] * direct;
    colour[c] = sample.albedo[c] * (params.ambient + params.diffuse * lambert * light_c) +
                params.specular * sample.gloss * highlight * light_c;
  }
  colour[3] = sample.alpha;
  return colour;
}

}  // namespace psrig::preview
