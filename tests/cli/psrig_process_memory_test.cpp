// psrig process within a memory budget: a 12 MP knitted scan, shadows and
// all (so the masked integration runs, the pipeline's hungriest path), under
// an address-space limit of 768 MiB, gives the very maps of a run without
// one. The budget itself (512 MB resident) and the time are the benchmark's
// (BM_Process/12MP_knit), never a test's.

#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;

constexpr std::size_t kLimit = std::size_t{768} << 20;

// report.json without what differs from run to run: times and memory.
nlohmann::json stable_report(const fs::path& maps) {
  nlohmann::json report = nlohmann::json::parse(file_contents(maps / "report.json"));
  for (const char* key : {"timings_ms", "encode_ms", "memory_mb"})
    report.erase(key);
  return report;
}

TEST(PsrigProcessMemory, TwelveMegapixelKnitWithin768MiBGivesTheSameMaps) {
  // An address-space limit would be the emulator's: qemu reserves its own.
  if (programs_run_under_emulator())
    GTEST_SKIP() << "psrig runs under an emulator, whose address space is not the program's";
  TempDir temp;
  const fs::path scan = temp / "scan";
  const auto synth =
      run_program("psrig", {"synth", "--out", scan.string(), "--size", "4000x3000", "-q"});
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  // Two pool threads whatever the machine: each thread's stack counts
  // against the limit.
  const auto process = [&](const fs::path& out) -> std::vector<std::string> {
    return {"process", scan.string(), "--out", out.string(), "--threads", "2", "-q"};
  };
  const auto free = run_program("psrig", process(temp / "free"));
  ASSERT_EQ(free.exit_code, 0) << free.err;
  // RLIMIT_AS counts address space, not memory in use: besides what
  // processing holds, the ~200 MB of libraries OpenCV maps, the pool
  // threads' stacks, and 64 MB that glibc reserves for each thread's malloc
  // arena as it first allocates (little of it ever used here: every large
  // buffer is its own mapping). One arena keeps the limit about processing.
  const auto limited =
      run_program_limited("psrig", process(temp / "limited"), kLimit, {"MALLOC_ARENA_MAX=1"});
  ASSERT_EQ(limited.exit_code, 0) << limited.err;

  const nlohmann::json report = stable_report(temp / "free");
  EXPECT_EQ(report["height"]["method"], "masked");  // the knit's shadows: the masked path
  EXPECT_GT(report["pixels"]["shadowed"].get<double>(), 0.1 * 4000 * 3000);
  EXPECT_EQ(stable_report(temp / "limited"), report);
  const std::vector<std::string> files = list_directory(temp / "free");
  EXPECT_EQ(list_directory(temp / "limited"), files);
  for (const std::string& file : files) {
    if (file == "report.json") continue;
    EXPECT_TRUE(file_contents(temp / "free" / file) == file_contents(temp / "limited" / file))
        << file << " differs";
  }
}

}  // namespace
}  // namespace psrig::test
