// The [daemon] table of rig.toml: defaults, checks that name the key, and
// the rule that nothing listens off this machine without a token.

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "psrig/config/config_loader.h"
#include "psrig/daemon/http_api.h"

namespace psrig::test {
namespace {

using config::parse_config;

TEST(DaemonConfig, DefaultsListenOnLoopbackWithoutModbus) {
  auto config = parse_config("", "rig.toml");
  ASSERT_TRUE(config) << config.error().describe();
  EXPECT_EQ(config->daemon.listen_address, "127.0.0.1");
  EXPECT_EQ(config->daemon.port, 8470);
  EXPECT_EQ(config->daemon.queue_limit, 16);
  EXPECT_EQ(config->daemon.modbus_port, 0);
  EXPECT_TRUE(config->daemon.token.empty());
}

TEST(DaemonConfig, KeysAreRead) {
  auto config = parse_config(
      "[daemon]\nlisten_address = \"0.0.0.0\"\nport = 9000\ntoken = \"0123456789abcdef0123\"\n"
      "queue_limit = 3\nmodbus_address = \"0.0.0.0\"\nmodbus_port = 1502\n",
      "rig.toml");
  ASSERT_TRUE(config) << config.error().describe();
  EXPECT_EQ(config->daemon.listen_address, "0.0.0.0");
  EXPECT_EQ(config->daemon.port, 9000);
  EXPECT_EQ(config->daemon.token, "0123456789abcdef0123");
  EXPECT_EQ(config->daemon.queue_limit, 3);
  EXPECT_EQ(config->daemon.modbus_address, "0.0.0.0");
  EXPECT_EQ(config->daemon.modbus_port, 1502);
}

struct BadDaemon {
  const char* text;
  const char* key;  // what the message must name
};

TEST(DaemonConfig, ErrorsNameTheKey) {
  for (const auto& bad : {
           BadDaemon{"[daemon]\nport = 0\n", "daemon.port"},
           BadDaemon{"[daemon]\nport = \"8470\"\n", "daemon.port"},
           BadDaemon{"[daemon]\nqueue_limit = 0\n", "daemon.queue_limit"},
           BadDaemon{"[daemon]\nmodbus_port = 70000\n", "daemon.modbus_port"},
           BadDaemon{"[daemon]\nlisten_address = \"\"\n", "daemon.listen_address"},
           BadDaemon{"[daemon]\ntoken = \"short\"\n", "daemon.token"},
           BadDaemon{"[daemon]\nlisten_address = \"0.0.0.0\"\n", "daemon.token"},
           BadDaemon{"daemon = 3\n", "daemon"},
       }) {
    auto config = parse_config(bad.text, "rig.toml");
    ASSERT_FALSE(config) << bad.text;
    EXPECT_NE(config.error().describe().find(bad.key), std::string::npos)
        << bad.text << ": " << config.error().describe();
    EXPECT_NE(config.error().describe().find("rig.toml:"), std::string::npos);
  }
}

TEST(DaemonConfig, ModbusAllowListsThePlcsIpv4Addresses) {
  auto config = parse_config(
      "[daemon]\nmodbus_port = 502\nmodbus_allow = [\"192.0.2.10\", \"192.0.2.11\"]\n", "rig.toml");
  ASSERT_TRUE(config) << config.error().describe();
  EXPECT_EQ(config->daemon.modbus_allow, (std::vector<std::string>{"192.0.2.10", "192.0.2.11"}));
  auto defaults = parse_config("", "rig.toml");
  ASSERT_TRUE(defaults) << defaults.error().describe();
  EXPECT_TRUE(defaults->daemon.modbus_allow.empty());

  for (const char* bad :
       {"[daemon]\nmodbus_allow = \"192.0.2.10\"\n",
        "[daemon]\nmodbus_allow = [\"192.0.2.10\", 7]\n",
        "[daemon]\nmodbus_allow = [\"plc.local\"]\n", "[daemon]\nmodbus_allow = [\"::1\"]\n"}) {
    auto refused = parse_config(bad, "rig.toml");
    ASSERT_FALSE(refused) << bad;
    EXPECT_NE(refused.error().describe().find("daemon.modbus_allow"), std::string::npos)
        << refused.error().describe();
    EXPECT_NE(refused.error().describe().find("rig.toml:"), std::string::npos);
  }
}

TEST(DaemonConfig, ModbusOffLoopbackWithoutAnAllowListIsAWarning) {
  std::vector<std::string> warnings;
  auto open = parse_config("[daemon]\nmodbus_address = \"0.0.0.0\"\nmodbus_port = 502\n",
                           "rig.toml", &warnings);
  ASSERT_TRUE(open) << open.error().describe();
  ASSERT_EQ(warnings.size(), 1u);
  for (const char* part : {"rig.toml:2:", "daemon.modbus_address", "0.0.0.0", "daemon.modbus_allow",
                           "502", "trigger scans", "127.0.0.1"})
    EXPECT_NE(warnings[0].find(part), std::string::npos) << part << " in " << warnings[0];

  // An allow-list, a loopback address, or no Modbus server at all: nothing to say.
  for (const char* fine : {"[daemon]\nmodbus_address = \"0.0.0.0\"\nmodbus_port = 502\n"
                           "modbus_allow = [\"192.0.2.10\"]\n",
                           "[daemon]\nmodbus_address = \"127.0.0.1\"\nmodbus_port = 502\n",
                           "[daemon]\nmodbus_address = \"0.0.0.0\"\nmodbus_port = 0\n"}) {
    warnings.clear();
    auto config = parse_config(fine, "rig.toml", &warnings);
    ASSERT_TRUE(config) << config.error().describe();
    EXPECT_TRUE(warnings.empty()) << fine << ": " << warnings.front();
  }
}

TEST(DaemonConfig, LoopbackAddresses) {
  for (const char* address : {"127.0.0.1", "127.1.2.3", "::1", "localhost"})
    EXPECT_TRUE(config::is_loopback_address(address)) << address;
  for (const char* address : {"0.0.0.0", "::", "192.168.1.10", "128.0.0.1", "example.org", ""})
    EXPECT_FALSE(config::is_loopback_address(address)) << address;
}

TEST(DaemonConfig, TokensCompareWhole) {
  using daemon::constant_time_equal;
  EXPECT_TRUE(constant_time_equal("Bearer abc", "Bearer abc"));
  EXPECT_FALSE(constant_time_equal("Bearer abc", "Bearer abd"));
  EXPECT_FALSE(constant_time_equal("Bearer ab", "Bearer abc"));
  EXPECT_FALSE(constant_time_equal("Bearer abc", "Bearer ab"));
  EXPECT_FALSE(constant_time_equal("", "Bearer abc"));
}

TEST(DaemonConfig, OnlyWhitelistedFilesAreServed) {
  using daemon::scan_file_home;
  using daemon::ScanFileHome;
  EXPECT_EQ(scan_file_home("scan.json"), ScanFileHome::scan);
  EXPECT_EQ(scan_file_home("led2.png"), ScanFileHome::scan);
  EXPECT_EQ(scan_file_home("normal.png"), ScanFileHome::maps);
  EXPECT_EQ(scan_file_home("report.json"), ScanFileHome::maps);
  // Whatever the scan layout allows: float frames are EXR files.
  EXPECT_EQ(scan_file_home("led2.exr"), ScanFileHome::scan);
  EXPECT_EQ(scan_file_home("dark.exr"), ScanFileHome::scan);
  EXPECT_EQ(scan_file_home("mask.png"), ScanFileHome::maps);
  for (const char* name : {"..", "../scan.json", "/etc/passwd", "catalogue.sqlite", "led01.png",
                           "led2.jpg", "maps", "", "scan.json/", "NORMAL.PNG"})
    EXPECT_FALSE(scan_file_home(name)) << name;
}

}  // namespace
}  // namespace psrig::test
