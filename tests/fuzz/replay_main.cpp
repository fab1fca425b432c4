// Replays files through a fuzz target's LLVMFuzzerTestOneInput without
// libFuzzer: the ctest fuzz.replay.<target> in the normal (GCC) build.
// Arguments are files or directories (every regular file in them, sorted).
// A file whose name ends in ".known-failing" is a crash found and not yet
// fixed: it is listed and skipped, so the test passes until someone fixes
// the bug and drops the suffix. A crash fails the test as it would fail the
// fuzzer (abort, sanitizer report); each file is named before it runs.

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz_target.h"

namespace fs = std::filesystem;

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) __attribute__((weak));

int main(int argc, char** argv) {
  if (LLVMFuzzerInitialize) LLVMFuzzerInitialize(&argc, &argv);
  std::vector<fs::path> files;
  for (int i = 1; i < argc; ++i) {
    const fs::path arg = argv[i];
    if (fs::is_directory(arg)) {
      std::vector<fs::path> found;
      for (const auto& entry : fs::recursive_directory_iterator(arg))
        if (entry.is_regular_file() && entry.path().filename() != "README.md")
          found.push_back(entry.path());
      std::sort(found.begin(), found.end());
      files.insert(files.end(), found.begin(), found.end());
    } else if (fs::is_regular_file(arg)) {
      files.push_back(arg);
    } else if (!fs::exists(arg)) {
      std::fprintf(stderr, "replay: %s: no such file or directory (skipped)\n", arg.c_str());
    }
  }
  int replayed = 0, known_failing = 0;
  for (const auto& file : files) {
    if (file.extension() == ".known-failing") {
      std::fprintf(stderr, "replay: %s: known failing, skipped\n", file.c_str());
      ++known_failing;
      continue;
    }
    std::ifstream in(file, std::ios::binary);
    const std::vector<char> bytes{std::istreambuf_iterator<char>(in), {}};
    std::fprintf(stderr, "replay: %s (%zu bytes)\n", file.c_str(), bytes.size());
    LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
    ++replayed;
  }
  std::printf("replay: %d inputs replayed, %d known failing skipped\n", replayed, known_failing);
  return replayed > 0 ? 0 : 1;
}
