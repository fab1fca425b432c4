#include "export_target.h"

namespace psrig::export_ {
namespace fs = std::filesystem;

Result<formats::AtomicDirectory::Existing> check_directory_target(const fs::path& out,
                                                                  const std::string& main_file) {
  std::error_code ec;
  const auto status = fs::symlink_status(out, ec);
  if (!fs::exists(status)) return formats::AtomicDirectory::Existing::refuse;
  if (fs::is_directory(status) &&
      (fs::is_empty(out, ec) || fs::is_regular_file(out / main_file, ec)))
    return formats::AtomicDirectory::Existing::replace;
  return std::unexpected(bad_input(out, "--out",
                                   "exists and is not an earlier export; refusing to replace it "
                                   "(choose another --out, or remove it)"));
}

}  // namespace psrig::export_
