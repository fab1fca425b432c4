#include "psrig/preview/offscreen_target.h"

#include <GLES3/gl3.h>
#include <algorithm>

#include <opencv2/imgproc.hpp>

namespace psrig::preview {
namespace {

// A framebuffer with a colour and a depth renderbuffer of `samples` (0: plain).
bool make_framebuffer(cv::Size size, int samples, ColourStorage storage, unsigned& framebuffer,
                      unsigned& colour, unsigned* depth) {
  glGenFramebuffers(1, &framebuffer);
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer);
  glGenRenderbuffers(1, &colour);
  glBindRenderbuffer(GL_RENDERBUFFER, colour);
  const GLenum format = storage == ColourStorage::srgb ? GL_SRGB8_ALPHA8 : GL_RGBA8;
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples, format, size.width, size.height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour);
  if (depth != nullptr) {
    glGenRenderbuffers(1, depth);
    glBindRenderbuffer(GL_RENDERBUFFER, *depth);
    glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples, GL_DEPTH_COMPONENT24, size.width,
                                     size.height);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, *depth);
  }
  return glCheckFramebufferStatus(GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
}

}  // namespace

Result<std::unique_ptr<OffscreenTarget>> OffscreenTarget::create(cv::Size size, int samples,
                                                                 ColourStorage storage) {
  GLint max_size = 0, max_samples = 0;
  glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_size);
  glGetIntegerv(GL_MAX_SAMPLES, &max_samples);
  if (size.width <= 0 || size.height <= 0 || size.width > max_size || size.height > max_size)
    return std::unexpected(bad_input("", "--size",
                                     std::to_string(size.width) + "x" +
                                         std::to_string(size.height) +
                                         " is not a frame size this GL can draw (at most " +
                                         std::to_string(max_size) + " a side)"));
  std::unique_ptr<OffscreenTarget> target(new OffscreenTarget);
  target->size_ = size;
  target->samples_ = std::clamp(samples, 0, max_samples);
  target->storage_ = storage;
  if (!make_framebuffer(size, target->samples_, storage, target->framebuffer_, target->colour_,
                        &target->depth_))
    return std::unexpected(io_error("GLES", "the offscreen framebuffer is incomplete"));
  if (target->samples_ > 0 && !make_framebuffer(size, 0, storage, target->resolve_framebuffer_,
                                                target->resolve_colour_, nullptr))
    return std::unexpected(io_error("GLES", "the resolve framebuffer is incomplete"));
  return target;
}

OffscreenTarget::~OffscreenTarget() {
  const GLuint framebuffers[] = {framebuffer_, resolve_framebuffer_};
  const GLuint renderbuffers[] = {colour_, depth_, resolve_colour_};
  glDeleteFramebuffers(2, framebuffers);
  glDeleteRenderbuffers(3, renderbuffers);
}

void OffscreenTarget::bind() const {
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_);
  glViewport(0, 0, size_.width, size_.height);
}

cv::Mat OffscreenTarget::read() const {
  GLuint source = framebuffer_;
  if (samples_ > 0) {  // resolve the samples into one value per pixel first
    glBindFramebuffer(GL_READ_FRAMEBUFFER, framebuffer_);
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, resolve_framebuffer_);
    glBlitFramebuffer(0, 0, size_.width, size_.height, 0, 0, size_.width, size_.height,
                      GL_COLOR_BUFFER_BIT, GL_NEAREST);
    source = resolve_framebuffer_;
  }
  glBindFramebuffer(GL_READ_FRAMEBUFFER, source);
  cv::Mat rgba(size_, CV_8UC4);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, size_.width, size_.height, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data);
  cv::Mat bgr;
  cv::cvtColor(rgba, bgr, cv::COLOR_RGBA2BGR);
  cv::flip(bgr, bgr, 0);
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_);
  return bgr;
}

}  // namespace psrig::preview
