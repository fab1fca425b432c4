#pragma once
// Helpers shared by the tests: scratch directories, the real datasets, and
// the paths of the built programs.

#include <expected>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace psrig::test {

// A fresh directory under the system temp dir, removed with its contents
// when the object goes away.
class TempDir {
 public:
  explicit TempDir(const std::string& prefix = "psrig-test");
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  [[nodiscard]] std::filesystem::path operator/(const std::string& name) const {
    return path_ / name;
  }

 private:
  std::filesystem::path path_;
};

// A folder of ../shared/data (or $PSRIG_DATA_DIR), or nothing when absent:
// tests on real data skip, never fail, without it.
[[nodiscard]] std::optional<std::filesystem::path> real_dataset(const std::string& name);

// A knit chart or weave matrix shipped in config/patterns, e.g. "garter.chart".
[[nodiscard]] std::filesystem::path shipped_pattern(const std::string& name);

// The shipped patterns by name, as psrig synth takes them (stockinette,
// garter, rib-1x1, rib-2x2, seed, basketweave, stripes, plain, twill-2x2,
// satin-5).
[[nodiscard]] const std::vector<const char*>& shipped_pattern_names();

// `name` as a GoogleTest parameter's name: letters, digits and '_' only
// ("rib-1x1" -> "rib_1x1").
[[nodiscard]] std::string test_name(std::string name);

// A program built into build/bin, e.g. "psrig".
[[nodiscard]] std::filesystem::path program(const std::string& name);

// Whether the built programs run under an emulator (a cross build's tests,
// through qemu): then their memory and timing are the emulator's too.
[[nodiscard]] bool programs_run_under_emulator();

// How to start a built program: its path then `args`, behind the
// emulator's words in a cross build (its tests run through qemu, which
// runs only the first program itself). argv() points into it, for exec.
class ProgramCommand {
 public:
  ProgramCommand(const std::string& name, const std::vector<std::string>& args);
  [[nodiscard]] const std::string& file() const { return words_.front(); }
  [[nodiscard]] char* const* argv() const { return pointers_.data(); }

 private:
  std::vector<std::string> words_;
  std::vector<char*> pointers_;
};

struct ProgramRun {
  int exit_code = -1;
  std::string out;  // standard output
  std::string err;  // standard error
};

// Runs a built program with `args` and waits for it.
[[nodiscard]] ProgramRun run_program(const std::string& name, const std::vector<std::string>& args);

// The same under an address-space limit (setrlimit(RLIMIT_AS) in the child,
// in bytes), with `environment` (NAME=VALUE each) added to the child's.
[[nodiscard]] ProgramRun run_program_limited(const std::string& name,
                                             const std::vector<std::string>& args,
                                             std::size_t address_space,
                                             const std::vector<std::string>& environment = {});

// A field of another process's /proc/PID/status in kB ("VmRSS": resident
// now, "VmHWM": its peak); -1 where there is none.
[[nodiscard]] long process_status_kb(int pid, const std::string& field);

// Resets process `pid`'s peak (VmHWM) to its resident set now (clear_refs);
// false where that cannot be done.
bool reset_peak_resident(int pid);

// `psrig synth --pattern PATTERN` at SIZE (WxH) and PIXEL_SIZE mm into
// `scan`, then `psrig process`: the maps directory, or the failing step's
// stderr.
[[nodiscard]] std::expected<std::filesystem::path, std::string> synth_and_process(
    const std::filesystem::path& scan, const std::string& pattern,
    const std::string& size = "400x320", const std::string& pixel_size = "0.03");

// Whether `part` occurs in `text` (a program's output, an error).
[[nodiscard]] inline bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// A JSON file parsed (scan.json, report.json, calibration.json); throws
// when it is not JSON, failing the test that reads it.
[[nodiscard]] nlohmann::json read_json(const std::filesystem::path& file);

// How many calibration versions a storage root holds (STATE/calibrations).
[[nodiscard]] std::size_t calibration_versions(const std::filesystem::path& state);

// The file's bytes; empty when it cannot be read.
[[nodiscard]] std::string file_contents(const std::filesystem::path& file);

// Names in `directory`, hidden ones included, sorted.
[[nodiscard]] std::vector<std::string> list_directory(const std::filesystem::path& directory);

}  // namespace psrig::test
