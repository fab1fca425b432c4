#pragma once
// What both EGL contexts (surfaceless and KMS) report the same way: EGL
// errors in words, EGL's extensions, and the current GL context's name and
// extensions. extension_listed() (psrig/preview/extension_list.h) reads
// the lists.

#include <EGL/egl.h>
#include <string>
#include <string_view>

namespace psrig::preview {

// "WHAT failed (EGL error 0x3001)" with EGL's last error.
[[nodiscard]] std::string egl_error(const std::string& what);

// The current context's "renderer, version".
[[nodiscard]] std::string gl_description();

// EGL's extensions of `display`, or its client extensions for
// EGL_NO_DISPLAY; empty when EGL gives none.
[[nodiscard]] std::string_view egl_extension_list(EGLDisplay display);

// The current context's GL extensions, space separated.
[[nodiscard]] std::string gl_extension_list();

}  // namespace psrig::preview
