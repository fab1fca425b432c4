#pragma once
// What both EGL contexts (surfaceless and KMS) report the same way: EGL
// errors in words, and the current GL context's name and extensions.

#include <string>
#include <string_view>

namespace psrig::preview {

// "WHAT failed (EGL error 0x3001)" with EGL's last error.
[[nodiscard]] std::string egl_error(const std::string& what);

// The current context's "renderer, version".
[[nodiscard]] std::string gl_description();

// The current context's GL extensions, space separated with a space on
// either end, for extension_listed().
[[nodiscard]] std::string gl_extension_list();
[[nodiscard]] bool extension_listed(const std::string& list, std::string_view name);

}  // namespace psrig::preview
