// No LED stays lit after psrigd dies, however it dies: a GPIO line or a
// Modbus LED driver keeps the state the dead process left it in. The unit's
// ExecStopPost= (config/systemd/psrigd.service) switches them off after any
// end, and the daemon does at start-up. Here on the simulated Modbus driver,
// which keeps its outputs whoever talks to it, as a real one does, and on
// the simulated lights with their switch log in a file
// (lights.sim.switch_log), which outlives the killed process.

#include <algorithm>
#include <chrono>
#include <csignal>
#include <fstream>
#include <iostream>
#include <modbus.h>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "daemon_process.h"
#include "psrig/lights/switch_log_file.h"
#include "sim_modbus_driver.h"

namespace psrig::test {
namespace {

using Clock = std::chrono::steady_clock;

// Switches LED `channel` on the way a process that then died would have.
void light(const SimModbusDriver& driver, int channel) {
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", driver.port());
  ASSERT_NE(ctx, nullptr);
  modbus_set_slave(ctx, driver.host_config().slave);
  ASSERT_EQ(modbus_connect(ctx), 0) << modbus_strerror(errno);
  EXPECT_EQ(modbus_write_bit(ctx, driver.host_config().registers.enable_coil + channel, 1), 1)
      << modbus_strerror(errno);
  modbus_close(ctx);
  modbus_free(ctx);
  ASSERT_EQ(driver.leds_on(), std::vector<int>{channel});
}

// Polls until no LED is on, at most `limit`; whether they all went off.
bool wait_dark(const SimModbusDriver& driver, std::chrono::milliseconds limit) {
  const auto deadline = Clock::now() + limit;
  while (!driver.leds_on().empty()) {
    if (Clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

// The unit's ExecStopPost= command line, split into words.
std::vector<std::string> unit_stop_post_command() {
  std::ifstream unit(fs::path(PSRIG_SOURCE_DIR) / "config/systemd/psrigd.service");
  std::string line;
  while (std::getline(unit, line)) {
    if (!line.starts_with("ExecStopPost=")) continue;
    std::istringstream words(line.substr(line.find('=') + 1));
    std::vector<std::string> command;
    for (std::string word; words >> word;)
      command.push_back(word);
    return command;
  }
  return {};
}

TEST(LedsDarkAfterDeath, TheDaemonSwitchesAnLedLeftLitOffAtStartUp) {
  TempDir temp;
  auto driver = SimModbusDriver::start({});
  ASSERT_TRUE(driver) << driver.error().describe();
  light(**driver, 1);
  const int port = free_port();
  Daemon daemon(daemon_config(temp, port, {modbus_lights((*driver)->port())}), port,
                temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  EXPECT_TRUE(wait_dark(**driver, std::chrono::seconds(5))) << daemon.log();
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

// kill -9 mid-scan leaves an LED lit; the unit's own stop command, as
// systemd runs it after any end (psrig and the configuration as the test
// has them), switches it off. How long it stayed lit is printed.
TEST(LedsDarkAfterDeath, TheUnitsStopCommandSwitchesOffWhatAKilledDaemonLeftLit) {
  auto command = unit_stop_post_command();
  ASSERT_EQ(command.size(), 5U) << "ExecStopPost=/usr/bin/psrig lights --config FILE --off";
  ASSERT_EQ(command[0], "/usr/bin/psrig");
  ASSERT_EQ(command[2], "--config");

  TempDir temp;
  auto driver = SimModbusDriver::start({});
  ASSERT_TRUE(driver) << driver.error().describe();
  const int port = free_port();
  const auto config = daemon_config(
      temp, port,
      {modbus_lights((*driver)->port()), {"exposure_us = 20000", "exposure_us = 200000"}});
  Daemon daemon(config, port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  ASSERT_GT(daemon.submit({{"sample_id", "KILLED"}}), 0);
  const auto lit_by = Clock::now() + std::chrono::seconds(10);
  while ((*driver)->leds_on().empty() && Clock::now() < lit_by)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_FALSE((*driver)->leds_on().empty()) << "no LED came on" << daemon.log();

  const auto killed = Clock::now();
  EXPECT_EQ(daemon.signal_and_wait(SIGKILL), 128 + SIGKILL);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  ASSERT_FALSE((*driver)->leds_on().empty()) << "nothing to switch off: the test proves nothing";

  const auto run = run_program("psrig", {command[1], command[2], config.string(), command[4]});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE((*driver)->leds_on().empty()) << run.out << run.err;
  const auto lit_ms =
      std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - killed).count();
  std::cout << "an LED stayed lit " << lit_ms << " ms after kill -9 (200 ms of it waiting)\n";
  EXPECT_LE(lit_ms, 2000);
  EXPECT_FALSE((*driver)->log().overlap()) << *(*driver)->log().overlap();
}

using lights::LoggedSwitch;
using lights::read_switch_log_file;

std::vector<LoggedSwitch> read_switches(const fs::path& file) {
  auto read = read_switch_log_file(file);
  EXPECT_TRUE(read) << read.error().describe();
  return read ? *read : std::vector<LoggedSwitch>{};
}

// The channel the log leaves on, if any.
std::optional<int> lit(const std::vector<LoggedSwitch>& switches) {
  lights::SwitchLog log;
  lights::replay(switches, log);
  const auto on = log.on_now();
  return on.empty() ? std::nullopt : std::optional<int>(on.front());
}

// The same on the simulated lights, measured from their switch log file:
// psrigd is killed just after an LED went on, the unit's stop command (a
// separate process, which never switched that LED on) switches everything
// off and says so in the same file, within 2 s of the kill.
TEST(LedsDarkAfterDeath, TheSimulatedLightsLogShowsTheStopCommandSwitchingOffAKilledDaemonsLed) {
  auto command = unit_stop_post_command();
  ASSERT_EQ(command.size(), 5U) << "ExecStopPost=/usr/bin/psrig lights --config FILE --off";

  TempDir temp;
  const fs::path switches = temp / "switches.log";
  const int port = free_port();
  const auto config =
      daemon_config(temp, port,
                    {{"max_on_ms = 5000", "max_on_ms = 5000\n\n[lights.sim]\nswitch_log = \"" +
                                              switches.string() + "\""},
                     {"exposure_us = 20000", "exposure_us = 200000"}});
  Daemon daemon(config, port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  const pid_t daemon_pid = daemon.pid();
  ASSERT_GT(daemon.submit({{"sample_id", "KILLED"}}), 0);
  // Wait for an LED that has just gone on, so the kill lands while it is lit.
  std::optional<int> channel;
  const auto lit_by = Clock::now() + std::chrono::seconds(10);
  while (Clock::now() < lit_by) {
    const auto so_far = read_switches(switches);
    if (!so_far.empty() && so_far.back().event.on &&
        Clock::now() - so_far.back().event.time < std::chrono::milliseconds(50)) {
      channel = so_far.back().event.channel;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_TRUE(channel) << "no LED came on\n" << file_contents(switches) << daemon.log();

  const auto killed = Clock::now();
  EXPECT_EQ(daemon.signal_and_wait(SIGKILL), 128 + SIGKILL);
  const auto at_death = read_switches(switches);
  ASSERT_EQ(lit(at_death), channel) << "nothing left lit: the test proves nothing\n"
                                    << file_contents(switches);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));

  const auto run = run_program("psrig", {command[1], command[2], config.string(), command[4]});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  const auto after = read_switches(switches);
  ASSERT_GT(after.size(), at_death.size()) << "psrig lights --off wrote nothing to the log";
  // The first switch after the kill: the stop command's, all off.
  const LoggedSwitch& off = after[at_death.size()];
  EXPECT_NE(off.pid, daemon_pid);
  EXPECT_EQ(off.event.channel, -1);
  EXPECT_FALSE(off.event.on);
  for (std::size_t i = at_death.size(); i < after.size(); ++i) {
    EXPECT_NE(after[i].pid, daemon_pid) << "the dead daemon switched at line " << i + 1;
    EXPECT_FALSE(after[i].event.on) << "line " << i + 1;
  }
  EXPECT_FALSE(lit(after)) << file_contents(switches);
  lights::SwitchLog log;
  lights::replay(after, log);
  EXPECT_FALSE(log.overlap()) << *log.overlap();

  const auto ms = [](Clock::duration d) {
    return std::chrono::duration_cast<std::chrono::milliseconds>(d).count();
  };
  const auto switched_on = std::find_if(at_death.rbegin(), at_death.rend(), [&](const auto& s) {
                             return s.event.on && s.event.channel == *channel;
                           })->event.time;
  std::cout << "LED " << *channel << " stayed lit " << ms(off.event.time - killed)
            << " ms after kill -9 (200 ms of it waiting), " << ms(off.event.time - switched_on)
            << " ms in all\n";
  EXPECT_GE(off.event.time, killed);
  EXPECT_LE(off.event.time - killed, std::chrono::seconds(2));
}

}  // namespace
}  // namespace psrig::test
