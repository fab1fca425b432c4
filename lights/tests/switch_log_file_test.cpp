// The simulated lights' switch log file (lights.sim.switch_log): every
// switch a line, from any number of processes, read back by the tests.

#include "psrig/lights/switch_log_file.h"

#include <fstream>
#include <iterator>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

#include <gtest/gtest.h>

#include "psrig/config/config_loader.h"
#include "psrig/lights/light_controller.h"
#include "psrig/rig/open_devices.h"
#include "test_support.h"

namespace psrig::lights {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

// A simulated rig whose lights log to `log` (the key as a user writes it).
config::RigConfig sim_rig(const fs::path& file, const std::string& log) {
  auto config = config::parse_config(
      "[lights]\nbackend = \"sim\"\n\n[lights.sim]\nswitch_log = \"" + log + "\"\n", file);
  EXPECT_TRUE(config) << config.error().describe();
  return config.value_or(config::RigConfig{});
}

TEST(SwitchLogFile, TheSimLightsAppendEverySwitchAsALine) {
  TempDir temp;
  // Relative to the configuration file, as storage.root is.
  const auto config = sim_rig(temp / "rig.toml", "switches.log");
  ASSERT_EQ(config.lights.sim.switch_log, temp / "switches.log");
  const auto before = Clock::now();
  {
    auto lights = psrig::rig::open_lights(config);
    ASSERT_TRUE(lights) << lights.error().describe();
    ASSERT_TRUE((*lights)->turn_on(1));
    // In the file as soon as the switch returns.
    auto so_far = read_switch_log_file(temp / "switches.log");
    ASSERT_TRUE(so_far) << so_far.error().describe();
    ASSERT_EQ(so_far->size(), 1U);
    ASSERT_TRUE((*lights)->all_off());
    ASSERT_TRUE((*lights)->turn_on(2));
    ASSERT_TRUE((*lights)->all_off());
  }
  auto read = read_switch_log_file(temp / "switches.log");
  ASSERT_TRUE(read) << read.error().describe();
  ASSERT_EQ(read->size(), 4U);
  const std::vector<std::pair<int, bool>> expected = {
      {1, true}, {-1, false}, {2, true}, {-1, false}};
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const auto& s = (*read)[i];
    EXPECT_EQ(s.event.channel, expected[i].first) << i;
    EXPECT_EQ(s.event.on, expected[i].second) << i;
    EXPECT_EQ(s.pid, ::getpid());
    EXPECT_GE(s.event.time, before);
    EXPECT_LE(s.event.time, Clock::now());
    if (i > 0) {
      EXPECT_GE(s.event.time, (*read)[i - 1].event.time);
    }
    EXPECT_LT(std::chrono::abs(s.wall - std::chrono::system_clock::now()), std::chrono::minutes(1));
  }
  SwitchLog log;
  replay(*read, log);
  EXPECT_FALSE(log.overlap());
  EXPECT_TRUE(log.on_now().empty());
  std::ifstream in(temp / "switches.log");
  const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  EXPECT_NE(text.find(" " + std::to_string(::getpid()) + " 1 on\n"), std::string::npos) << text;
  EXPECT_NE(text.find(" all off\n"), std::string::npos) << text;
}

// psrigd and the unit's `psrig lights --off` append to the same file: every
// line whole, in order of writing, each with its writer's pid.
TEST(SwitchLogFile, SeveralProcessesAppendWholeLines) {
  TempDir temp;
  const auto config = sim_rig(temp / "rig.toml", (temp / "switches.log").string());
  constexpr int kSwitches = 500;
  const auto cycle = [&] {
    auto lights = psrig::rig::open_lights(config);
    if (!lights) return false;
    for (int i = 0; i < kSwitches; ++i)
      if (!(*lights)->turn_on(i % 3) || !(*lights)->all_off()) return false;
    return true;
  };
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) ::_exit(cycle() ? 0 : 1);
  EXPECT_TRUE(cycle());
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);

  auto read = read_switch_log_file(temp / "switches.log");
  ASSERT_TRUE(read) << read.error().describe();
  ASSERT_EQ(read->size(), 4U * kSwitches);
  int mine = 0, theirs = 0;
  for (const auto& s : *read) {
    if (s.pid == ::getpid()) ++mine;
    if (s.pid == child) ++theirs;
  }
  EXPECT_EQ(mine, 2 * kSwitches);
  EXPECT_EQ(theirs, 2 * kSwitches);
}

TEST(SwitchLogFile, AMissingFileIsNoSwitchesAndAMalformedLineIsNamed) {
  TempDir temp;
  auto none = read_switch_log_file(temp / "absent.log");
  ASSERT_TRUE(none);
  EXPECT_TRUE(none->empty());
  std::ofstream(temp / "bad.log") << "1 2 3 0 on\n1 2 3 all on\n";
  auto bad = read_switch_log_file(temp / "bad.log");
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().line, 2) << bad.error().describe();
  std::ofstream(temp / "worse.log") << "1 2 3 x on\n";
  EXPECT_FALSE(read_switch_log_file(temp / "worse.log"));
}

TEST(SwitchLogFile, AFileThatCannotBeOpenedFailsTheBackendNamingIt) {
  TempDir temp;
  const auto config = sim_rig(temp / "rig.toml", "no/such/dir/switches.log");
  auto lights = psrig::rig::open_lights(config);
  ASSERT_FALSE(lights);
  EXPECT_NE(lights.error().describe().find("no/such/dir/switches.log"), std::string::npos)
      << lights.error().describe();
  EXPECT_NE(lights.error().describe().find("lights.sim.switch_log"), std::string::npos)
      << lights.error().describe();
}

}  // namespace
}  // namespace psrig::lights
