#include "psrig/preview/extension_list.h"

namespace psrig::preview {

bool extension_listed(std::string_view list, std::string_view name) {
  if (name.empty()) return false;
  while (!list.empty()) {
    const std::size_t end = list.find(' ');
    if (list.substr(0, end) == name) return true;
    if (end == std::string_view::npos) break;
    list.remove_prefix(end + 1);
  }
  return false;
}

}  // namespace psrig::preview
