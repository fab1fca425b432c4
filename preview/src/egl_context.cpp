#include "psrig/preview/egl_context.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl3.h>

#include "gl_context_facts.h"
#include "psrig/preview/extension_list.h"

namespace psrig::preview {
namespace {

Error egl_failure(const std::string& what) {
  return io_error("EGL", egl_error(what) +
                             "; is Mesa's EGL installed (libegl-mesa0, libgl1-mesa-dri)? "
                             "scripts/install-deps installs it");
}

}  // namespace

Result<std::unique_ptr<EglContext>> EglContext::open_surfaceless() {
  if (!extension_listed(egl_extension_list(EGL_NO_DISPLAY), "EGL_MESA_platform_surfaceless"))
    return std::unexpected(
        io_error("EGL",
                 "EGL_MESA_platform_surfaceless is not offered; headless rendering "
                 "needs Mesa's EGL (libegl-mesa0)"));
  EGLDisplay display =
      eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  if (display == EGL_NO_DISPLAY)
    return std::unexpected(egl_failure("eglGetPlatformDisplay(surfaceless)"));
  std::unique_ptr<EglContext> context(new EglContext);
  context->display_ = display;
  if (eglInitialize(display, nullptr, nullptr) != EGL_TRUE)
    return std::unexpected(egl_failure("eglInitialize"));
  if (eglBindAPI(EGL_OPENGL_ES_API) != EGL_TRUE)
    return std::unexpected(egl_failure("eglBindAPI(GLES)"));
  // Surfaceless: no config and no surface; everything draws into FBOs.
  const EGLint attributes[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 0,
                               EGL_NONE};
  EGLContext gl = eglCreateContext(display, EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, attributes);
  if (gl == EGL_NO_CONTEXT)
    return std::unexpected(egl_failure("eglCreateContext(GLES 3.0, no config)"));
  context->context_ = gl;
  if (eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, gl) != EGL_TRUE)
    return std::unexpected(egl_failure("eglMakeCurrent(surfaceless)"));
  glGetIntegerv(GL_MAJOR_VERSION, &context->major_);
  glGetIntegerv(GL_MINOR_VERSION, &context->minor_);
  if (context->major_ < 3)
    return std::unexpected(io_error(
        "EGL",
        "the context is GLES " + std::to_string(context->major_) + "; the preview needs GLES 3.0"));
  context->extensions_ = gl_extension_list();
  return context;
}

EglContext::~EglContext() {
  if (display_ == nullptr) return;
  eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  if (context_ != nullptr) eglDestroyContext(display_, context_);
  eglTerminate(display_);
}

std::string EglContext::describe() const {
  return gl_description();
}

bool EglContext::has_extension(std::string_view name) const {
  return extension_listed(extensions_, name);
}

}  // namespace psrig::preview
