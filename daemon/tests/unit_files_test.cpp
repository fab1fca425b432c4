// The files that install psrigd: the systemd unit (checked by
// systemd-analyze verify where it is installed), the udev rules and the
// sysusers entry, and that the three agree on users, groups and devices.

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "psrig/config/config_loader.h"
#include "psrig/config/rig_config.h"

namespace psrig {
namespace {

using ::testing::Contains;
using ::testing::HasSubstr;

const std::filesystem::path kConfig = std::filesystem::path(PSRIG_SOURCE_DIR) / "config";

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// KEY -> every value it is given, in order, across the unit's sections.
std::multimap<std::string, std::string> unit_settings(const std::string& text) {
  std::multimap<std::string, std::string> settings;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.empty() || line[0] == '#' || line[0] == '[') continue;
    const auto equals = line.find('=');
    if (equals == std::string::npos) continue;
    settings.emplace(line.substr(0, equals), line.substr(equals + 1));
  }
  return settings;
}

std::string setting(const std::multimap<std::string, std::string>& settings,
                    const std::string& key) {
  const auto found = settings.find(key);
  return found == settings.end() ? std::string() : found->second;
}

std::vector<std::string> values(const std::multimap<std::string, std::string>& settings,
                                const std::string& key) {
  std::vector<std::string> all;
  for (auto [it, end] = settings.equal_range(key); it != end; ++it)
    all.push_back(it->second);
  return all;
}

std::vector<std::string> words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> all;
  for (std::string word; in >> word;)
    all.push_back(word);
  return all;
}

// A tool of the host, or "" when it is not installed.
std::string find_tool(const std::string& name) {
  for (const char* dir : {"/usr/bin", "/bin", "/usr/sbin", "/sbin"}) {
    const auto path = std::filesystem::path(dir) / name;
    if (std::filesystem::exists(path)) return path;
  }
  return {};
}

struct ToolRun {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

ToolRun run_tool(const std::string& command) {
  ToolRun run;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return run;
  std::array<char, 512> buffer{};
  while (const std::size_t n = std::fread(buffer.data(), 1, buffer.size(), pipe))
    run.output.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

class TempRoot {
 public:
  TempRoot() {
    char pattern[] = "/tmp/psrig-units-XXXXXX";
    path_ = ::mkdtemp(pattern) ? pattern : "";
  }
  ~TempRoot() {
    if (!path_.empty()) std::filesystem::remove_all(path_);
  }
  TempRoot(const TempRoot&) = delete;
  TempRoot& operator=(const TempRoot&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

TEST(UnitFilesTest, ServiceIsANotifyServiceWithWatchdogUserAndSandbox) {
  const auto unit = unit_settings(read_file(kConfig / "systemd/psrigd.service"));
  EXPECT_EQ(setting(unit, "Type"), "notify");
  EXPECT_EQ(setting(unit, "NotifyAccess"), "main");
  EXPECT_EQ(setting(unit, "ExecStart"), "/usr/bin/psrigd --config /etc/psrig/rig.toml");
  EXPECT_EQ(setting(unit, "ExecReload"), "/bin/kill -HUP $MAINPID");
  // Every LED off after the daemon ends for any reason, with its own rig.toml.
  EXPECT_EQ(setting(unit, "ExecStopPost"),
            "/usr/bin/psrig lights --config /etc/psrig/rig.toml --off");
  EXPECT_EQ(setting(unit, "KillSignal"), "SIGTERM");
  EXPECT_EQ(setting(unit, "Restart"), "on-failure");
  EXPECT_FALSE(setting(unit, "WatchdogSec").empty());
  EXPECT_FALSE(setting(unit, "TimeoutStopSec").empty());
  EXPECT_EQ(setting(unit, "User"), "psrig");
  EXPECT_EQ(setting(unit, "Group"), "psrig");
  EXPECT_EQ(setting(unit, "StateDirectory"), "psrig");
  EXPECT_EQ(setting(unit, "ConfigurationDirectory"), "psrig");
  for (const char* key : {"ProtectSystem", "ProtectHome", "PrivateTmp", "NoNewPrivileges"})
    EXPECT_THAT(setting(unit, key), ::testing::AnyOf("strict", "yes")) << key;
  // Sandboxing that would lock the rig out of its own devices or network.
  EXPECT_TRUE(setting(unit, "PrivateDevices").empty());
  EXPECT_TRUE(setting(unit, "PrivateNetwork").empty());
  EXPECT_THAT(words(setting(unit, "RestrictAddressFamilies")),
              ::testing::UnorderedElementsAre("AF_UNIX", "AF_INET", "AF_INET6", "AF_NETLINK"));
  const auto devices = values(unit, "DeviceAllow");
  for (const char* device : {"char-gpiochip rw", "char-video4linux rw", "char-media rw",
                             "char-usb_device rw", "char-ttyUSB rw", "char-ttyACM rw"})
    EXPECT_THAT(devices, Contains(device));
}

// A catalogue server: psrigd with no rig, so no devices, no lights to
// switch off after it, no privileged port.
TEST(UnitFilesTest, CatalogueServiceRunsPsrigdWithoutTheRigsDevices) {
  const auto unit = unit_settings(read_file(kConfig / "systemd/psrig-catalogue.service"));
  EXPECT_EQ(setting(unit, "Type"), "notify");
  EXPECT_EQ(setting(unit, "ExecStart"), "/usr/bin/psrigd --config /etc/psrig/catalogue.toml");
  EXPECT_EQ(setting(unit, "Restart"), "on-failure");
  EXPECT_FALSE(setting(unit, "WatchdogSec").empty());
  EXPECT_EQ(setting(unit, "User"), "psrig");
  EXPECT_EQ(setting(unit, "PrivateDevices"), "yes");
  EXPECT_TRUE(values(unit, "DeviceAllow").empty());
  EXPECT_TRUE(setting(unit, "ExecStopPost").empty());
  EXPECT_TRUE(setting(unit, "AmbientCapabilities").empty());
  EXPECT_THAT(words(setting(unit, "After")), Contains("network-online.target"));
  // The configuration it names is a catalogue server's.
  auto config = config::load_config(kConfig / "catalogue.example.toml");
  ASSERT_TRUE(config) << config.error().describe();
  EXPECT_EQ(config->daemon.role, "catalogue");
  EXPECT_TRUE(config::is_shared_catalogue(config->catalogue));
}

TEST(UnitFilesTest, SystemdAnalyzeVerifiesTheUnits) {
  const auto tool = find_tool("systemd-analyze");
  if (tool.empty()) GTEST_SKIP() << "systemd-analyze is not installed (Debian package systemd)";
  for (const std::string name : {"psrigd.service", "psrig-catalogue.service"}) {
    // psrigd and psrig are not installed on a build machine, and verify
    // checks that the programs the unit runs exist: the same unit, running
    // something that does.
    TempRoot dir;
    ASSERT_FALSE(dir.path().empty());
    std::string unit = read_file(kConfig / "systemd" / name);
    ASSERT_NE(unit.find("/usr/bin/psrigd "), std::string::npos) << name;
    for (const std::string program : {"/usr/bin/psrigd ", "/usr/bin/psrig "})
      if (const auto at = unit.find(program); at != std::string::npos)
        unit.replace(at, program.size(), "/bin/true ");
    std::ofstream(dir.path() / name) << unit;
    const auto run = run_tool(tool + " verify --man=no " + (dir.path() / name).string());
    EXPECT_EQ(run.exit_code, 0) << name << ": " << run.output;
    EXPECT_EQ(run.output, "") << name;  // unknown keys are only warned about
  }
}

TEST(UnitFilesTest, UdevRulesCoverTheDevicesForTheUnitsGroups) {
  const auto rules = read_file(kConfig / "udev/60-psrig.rules");
  // The strobe controller as the configuration finds it by default.
  const config::UsbLights usb;
  char ids[64];
  std::snprintf(ids, sizeof ids, "ATTR{idVendor}==\"%04x\", ATTR{idProduct}==\"%04x\"",
                usb.vendor_id, usb.product_id);
  EXPECT_THAT(rules, HasSubstr(ids));
  EXPECT_THAT(rules, HasSubstr("KERNEL==\"gpiochip[0-9]*\", GROUP=\"gpio\""));
  EXPECT_THAT(rules, HasSubstr("SUBSYSTEM==\"video4linux\", GROUP=\"video\""));
  EXPECT_THAT(rules, HasSubstr("ttyUSB[0-9]*"));

  // Every group a rule gives a device to is one psrigd runs in.
  const auto unit = unit_settings(read_file(kConfig / "systemd/psrigd.service"));
  const auto groups = words(setting(unit, "SupplementaryGroups"));
  std::istringstream lines(rules);
  std::string line;
  while (std::getline(lines, line)) {
    const auto at = line.find("GROUP=\"");
    if (line.empty() || line[0] == '#' || at == std::string::npos) continue;
    const auto group = line.substr(at + 7, line.find('"', at + 7) - at - 7);
    EXPECT_THAT(groups, Contains(group)) << line;
  }
}

TEST(UnitFilesTest, SysusersCreatesTheUserInEveryGroupTheUnitNames) {
  const auto unit = unit_settings(read_file(kConfig / "systemd/psrigd.service"));
  const auto groups = words(setting(unit, "SupplementaryGroups"));
  const auto sysusers = read_file(kConfig / "sysusers.d/psrig.conf");
  for (const auto& group : groups)
    EXPECT_THAT(sysusers, ::testing::ContainsRegex("m psrig +" + group + "\n")) << group;

  const auto tool = find_tool("systemd-sysusers");
  if (tool.empty()) GTEST_SKIP() << "systemd-sysusers is not installed (Debian package systemd)";
  // Applied to an empty root: the user, its group, and its memberships.
  TempRoot root;
  ASSERT_FALSE(root.path().empty());
  std::filesystem::create_directories(root.path() / "etc");
  const auto run = run_tool(tool + " --root=" + root.path().string() + " " +
                            (kConfig / "sysusers.d/psrig.conf").string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const auto passwd = read_file(root.path() / "etc/passwd");
  EXPECT_THAT(passwd, ::testing::ContainsRegex("psrig:x:[0-9]+:[0-9]+:psrig capture rig "
                                               "daemon:/var/lib/psrig:/usr/sbin/nologin"));
  const auto group_file = read_file(root.path() / "etc/group");
  EXPECT_THAT(group_file, ::testing::ContainsRegex("\npsrig:x:[0-9]+:|^psrig:x:[0-9]+:"));
  for (const auto& group : groups)
    EXPECT_THAT(group_file, ::testing::ContainsRegex(group + ":x:[0-9]+:psrig")) << group;
}

}  // namespace
}  // namespace psrig
