#include "test_support.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fcntl.h>
#include <fstream>
#include <random>
#include <spawn.h>
#include <sstream>
#include <string_view>
#include <sys/resource.h>
#include <sys/wait.h>
#include <system_error>
#include <unistd.h>

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

std::filesystem::path shipped_pattern(const std::string& name) {
  return std::filesystem::path(PSRIG_SOURCE_DIR) / "config" / "patterns" / name;
}

const std::vector<const char*>& shipped_pattern_names() {
  static const std::vector<const char*> names{"stockinette", "garter",      "rib-1x1", "rib-2x2",
                                              "seed",        "basketweave", "stripes", "plain",
                                              "twill-2x2",   "satin-5"};
  return names;
}

std::string test_name(std::string name) {
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return name;
}

std::filesystem::path program(const std::string& name) {
  return std::filesystem::path(PSRIG_BIN_DIR) / name;
}

bool programs_run_under_emulator() {
  return std::string_view(PSRIG_EMULATOR).size() > 0;
}

ProgramCommand::ProgramCommand(const std::string& name, const std::vector<std::string>& args) {
  // PSRIG_EMULATOR: its words joined by '|', empty in a native build.
  const std::string_view emulator = PSRIG_EMULATOR;
  for (std::size_t at = 0; at < emulator.size();) {
    const std::size_t end = std::min(emulator.find('|', at), emulator.size());
    words_.emplace_back(emulator.substr(at, end - at));
    at = end + 1;
  }
  words_.push_back(program(name).string());
  words_.insert(words_.end(), args.begin(), args.end());
  for (auto& word : words_)
    pointers_.push_back(word.data());
  pointers_.push_back(nullptr);
}

namespace {
std::string read_all(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}
}  // namespace

std::expected<std::filesystem::path, std::string> synth_and_process(
    const std::filesystem::path& scan, const std::string& pattern, const std::string& size,
    const std::string& pixel_size) {
  const auto synth = run_program("psrig", {"synth", "--out", scan.string(), "--pattern", pattern,
                                           "--size", size, "--pixel-size", pixel_size, "-q"});
  if (synth.exit_code != 0) return std::unexpected("psrig synth: " + synth.err);
  const auto process = run_program("psrig", {"process", scan.string(), "-q"});
  if (process.exit_code != 0) return std::unexpected("psrig process: " + process.err);
  return scan / "maps";
}

ProgramRun run_program(const std::string& name, const std::vector<std::string>& args) {
  TempDir capture("psrig-run");
  const auto out = capture / "out", err = capture / "err";
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  const ProgramCommand command(name, args);
  pid_t pid = 0;
  ProgramRun run;
  if (posix_spawn(&pid, command.file().c_str(), &actions, nullptr, command.argv(), environ) == 0) {
    int status = 0;
    waitpid(pid, &status, 0);
    run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  posix_spawn_file_actions_destroy(&actions);
  run.out = read_all(out);
  run.err = read_all(err);
  return run;
}

nlohmann::json read_json(const std::filesystem::path& file) {
  std::ifstream in(file);
  return nlohmann::json::parse(in);
}

std::size_t calibration_versions(const std::filesystem::path& state) {
  std::error_code ec;
  std::size_t n = 0;
  for (auto it = std::filesystem::directory_iterator(state / "calibrations", ec);
       !ec && it != std::filesystem::directory_iterator(); it.increment(ec))
    ++n;
  return n;
}

long process_status_kb(int pid, const std::string& field) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);)
    if (line.starts_with(field + ":")) return std::stol(line.substr(field.size() + 1));
  return -1;
}

bool reset_peak_resident(int pid) {
  std::ofstream clear_refs("/proc/" + std::to_string(pid) + "/clear_refs");
  clear_refs << "5" << std::flush;
  return clear_refs.good();
}

ProgramRun run_program_limited(const std::string& name, const std::vector<std::string>& args,
                               std::size_t address_space,
                               const std::vector<std::string>& environment) {
  TempDir capture("psrig-run");
  const auto out = capture / "out", err = capture / "err";
  // Everything the child needs is made before the fork: between fork and
  // exec a child of a threaded process may only make system calls.
  const std::string path = program(name).string();
  std::vector<char*> argv{const_cast<char*>(path.c_str())};
  for (const auto& arg : args)
    argv.push_back(const_cast<char*>(arg.c_str()));
  argv.push_back(nullptr);
  std::vector<char*> envp;
  for (char** variable = environ; *variable != nullptr; ++variable)
    envp.push_back(*variable);
  for (const auto& variable : environment)
    envp.push_back(const_cast<char*>(variable.c_str()));
  envp.push_back(nullptr);
  const rlimit limit{address_space, address_space};
  ProgramRun run;
  const pid_t pid = fork();
  if (pid == 0) {
    const int out_fd = open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err_fd = open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (out_fd < 0 || err_fd < 0 || dup2(out_fd, 1) < 0 || dup2(err_fd, 2) < 0 ||
        setrlimit(RLIMIT_AS, &limit) != 0)
      _exit(127);
    execve(path.c_str(), argv.data(), envp.data());
    _exit(127);
  }
  if (pid > 0) {
    int status = 0;
    waitpid(pid, &status, 0);
    run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  run.out = read_all(out);
  run.err = read_all(err);
  return run;
}

std::string file_contents(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

std::vector<std::string> list_directory(const std::filesystem::path& directory) {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(directory))
    names.push_back(entry.path().filename());
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace psrig::test
