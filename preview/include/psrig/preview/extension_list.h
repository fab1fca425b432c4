#pragma once
// Whether a space-separated extension list (EGL's client or display
// extensions, the GL context's) names an extension. Whole names only:
// "EGL_EXT_foo" is not in "EGL_EXT_foo_bar", which a substring search
// (strstr) would claim.

#include <string_view>

namespace psrig::preview {

[[nodiscard]] bool extension_listed(std::string_view list, std::string_view name);

}  // namespace psrig::preview
