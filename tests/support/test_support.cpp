#include "test_support.h"

#include <cstdlib>
#include <random>
#include <system_error>

namespace psrig::test {

TempDir::TempDir(const std::string& prefix) {
  std::random_device random;
  const auto base = std::filesystem::temp_directory_path();
  for (;;) {
    path_ = base / (prefix + "-" + std::to_string(random()));
    if (std::filesystem::create_directory(path_)) break;
  }
}

TempDir::~TempDir() {
  std::error_code ignored;
  std::filesystem::remove_all(path_, ignored);
}

std::optional<std::filesystem::path> real_dataset(const std::string& name) {
  const char* from_environment = std::getenv("PSRIG_DATA_DIR");
  const std::filesystem::path root =
      from_environment ? std::filesystem::path(from_environment)
                       : std::filesystem::path(PSRIG_SOURCE_DIR) / ".." / "shared" / "data";
  const auto folder = root / name;
  std::error_code ec;
  if (!std::filesystem::is_directory(folder, ec)) return std::nullopt;
  return folder;
}

std::filesystem::path program(const std::string& name) { return std::filesystem::path(PSRIG_BIN_DIR) / name; }

}  // namespace psrig::test
