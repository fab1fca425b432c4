#pragma once
// A GLES 3 context on EGL. Headless: EGL_MESA_platform_surfaceless, no
// window and no display, rendering into framebuffer objects (Mesa's
// llvmpipe gives one on any machine). The kiosk's GBM/KMS context comes
// later beside it. Current on the thread that opened it.

#include <memory>
#include <string>
#include <string_view>

#include "psrig/base/error.h"

namespace psrig::preview {

class EglContext {
 public:
  // GLES 3.0 or newer, or an error saying what EGL offered instead.
  [[nodiscard]] static Result<std::unique_ptr<EglContext>> open_surfaceless();
  ~EglContext();
  EglContext(const EglContext&) = delete;
  EglContext& operator=(const EglContext&) = delete;

  // "llvmpipe (LLVM 15.0.6, 256 bits), OpenGL ES 3.2 Mesa 22.3.6" and the like.
  [[nodiscard]] std::string describe() const;
  [[nodiscard]] int gles_major() const { return major_; }
  // A GL extension the context offers: detected, never assumed.
  [[nodiscard]] bool has_extension(std::string_view name) const;

 private:
  EglContext() = default;
  void* display_ = nullptr;  // EGLDisplay
  void* context_ = nullptr;  // EGLContext
  int major_ = 0, minor_ = 0;
  std::string extensions_;  // space separated
};

}  // namespace psrig::preview
