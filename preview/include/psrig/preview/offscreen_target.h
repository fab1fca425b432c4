#pragma once
// Where a headless frame is drawn: a framebuffer object with a colour and
// a depth renderbuffer, multisampled when asked (resolved on read-back),
// read back as an 8-bit BGR image ready for PNG. An sRGB target takes
// linear values from shaders and stores them sRGB encoded (blending and
// resolving in linear light); a linear one stores what it is given.

#include <opencv2/core.hpp>

#include "psrig/preview/egl_context.h"

namespace psrig::preview {

enum class ColourStorage { srgb, linear };

class OffscreenTarget {
 public:
  // `samples` 0: no multisampling; more is clamped to what the context
  // offers. Needs the context current.
  [[nodiscard]] static Result<std::unique_ptr<OffscreenTarget>> create(
      cv::Size size, int samples = 0, ColourStorage storage = ColourStorage::linear);
  ~OffscreenTarget();
  OffscreenTarget(const OffscreenTarget&) = delete;
  OffscreenTarget& operator=(const OffscreenTarget&) = delete;

  // Makes it the draw target, with the viewport set to it.
  void bind() const;
  // The frame as drawn, top row first (GL's is bottom first), CV_8UC3 BGR.
  [[nodiscard]] cv::Mat read() const;
  [[nodiscard]] cv::Size size() const { return size_; }
  [[nodiscard]] int samples() const { return samples_; }
  [[nodiscard]] ColourStorage storage() const { return storage_; }

 private:
  OffscreenTarget() = default;
  cv::Size size_;
  int samples_ = 0;
  ColourStorage storage_ = ColourStorage::linear;
  unsigned framebuffer_ = 0, colour_ = 0, depth_ = 0;
  unsigned resolve_framebuffer_ = 0, resolve_colour_ = 0;  // multisampled only
};

}  // namespace psrig::preview
