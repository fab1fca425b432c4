#pragma once
// Where a folder export (glTF, U3M) may go: a new directory, or one that
// holds an earlier export of the same name, which it replaces whole.

#include <filesystem>
#include <string>

#include "psrig/base/error.h"
#include "psrig/formats/atomic_directory.h"

namespace psrig::export_ {

// `out` may be replaced only when it is empty or holds `main_file` (an
// earlier export); anything else is refused, naming --out and the fix.
[[nodiscard]] Result<formats::AtomicDirectory::Existing> check_directory_target(
    const std::filesystem::path& out, const std::string& main_file);

}  // namespace psrig::export_
