#include "psrig/preview/clear_frame.h"

#include <GLES3/gl3.h>

#include "psrig/preview/shading.h"

namespace psrig::preview {

void clear_frame(cv::Vec3f linear, bool encode_srgb, cv::Size viewport) {
  const auto channel = [&](int c) { return encode_srgb ? srgb_encode(linear[c]) : linear[c]; };
  glViewport(0, 0, viewport.width, viewport.height);
  glClearColor(channel(0), channel(1), channel(2), 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
}

}  // namespace psrig::preview
