// The safety layer: never two LEDs on, and every way out leaves all off.

#include "psrig/lights/safe_lights.h"

#include <chrono>
#include <stdexcept>
#include <thread>

#include <gtest/gtest.h>

#include "psrig/lights/emergency_stop.h"

namespace psrig::lights {
namespace {

using namespace std::chrono_literals;

// A backend that does as told, remembers the state, and fails on request.
class FakeLights final : public LightController {
 public:
  struct State {
    std::vector<bool> on = std::vector<bool>(3, false);
    bool fail_on = false, fail_off = false;
    int off_calls = 0;
  };
  explicit FakeLights(std::shared_ptr<State> state) : state_(std::move(state)) {}
  int channel_count() const override { return 3; }
  Status turn_on(int channel) override {
    if (state_->fail_on)
      return std::unexpected(io_error("/dev/fake", "the driver stopped answering"));
    state_->on[channel] = true;
    log_.record(channel, true);
    return {};
  }
  Status all_off() override {
    ++state_->off_calls;
    if (state_->fail_off) return std::unexpected(io_error("/dev/fake", "stuck"));
    std::fill(state_->on.begin(), state_->on.end(), false);
    log_.record(-1, false);
    return {};
  }
  Status set_intensity(int, double) override { return {}; }
  std::string describe() const override { return "fake"; }

 private:
  std::shared_ptr<State> state_;
};

int lit_count(const FakeLights::State& state) {
  return static_cast<int>(std::count(state.on.begin(), state.on.end(), true));
}

TEST(SafeLights, OneAtATime) {
  auto state = std::make_shared<FakeLights::State>();
  SafeLights lights(std::make_unique<FakeLights>(state), 5s);
  for (int round = 0; round < 3; ++round)
    for (int channel : {0, 2, 1}) {
      ASSERT_TRUE(lights.turn_on(channel));
      EXPECT_EQ(lit_count(*state), 1);
      EXPECT_TRUE(state->on[channel]);
      EXPECT_EQ(lights.lit()->first, channel);
    }
  EXPECT_FALSE(lights.log().overlap()) << *lights.log().overlap();
  ASSERT_TRUE(lights.all_off());
  EXPECT_EQ(lit_count(*state), 0);
  EXPECT_FALSE(lights.lit());
}

TEST(SafeLights, BadChannelIsAnError) {
  auto state = std::make_shared<FakeLights::State>();
  SafeLights lights(std::make_unique<FakeLights>(state), 5s);
  EXPECT_FALSE(lights.turn_on(3));
  EXPECT_FALSE(lights.turn_on(-1));
  EXPECT_EQ(lit_count(*state), 0);
}

TEST(SafeLights, ABackendErrorEndsWithAllOff) {
  auto state = std::make_shared<FakeLights::State>();
  SafeLights lights(std::make_unique<FakeLights>(state), 5s);
  ASSERT_TRUE(lights.turn_on(0));
  state->fail_on = true;
  const int offs_before = state->off_calls;
  auto failed = lights.turn_on(1);
  ASSERT_FALSE(failed);
  EXPECT_NE(failed.error().message.find("all LEDs switched off"), std::string::npos)
      << failed.error().describe();
  EXPECT_EQ(lit_count(*state), 0);
  EXPECT_GE(state->off_calls, offs_before + 2);  // before the switch, and after the failure
}

TEST(SafeLights, AnOffThatFailsIsTriedAgainAndReported) {
  auto state = std::make_shared<FakeLights::State>();
  SafeLights lights(std::make_unique<FakeLights>(state), 5s);
  ASSERT_TRUE(lights.turn_on(0));
  state->fail_off = true;
  const int offs_before = state->off_calls;
  EXPECT_FALSE(lights.all_off());
  EXPECT_EQ(state->off_calls, offs_before + 2);
  state->fail_off = false;
}

TEST(SafeLights, WatchdogSwitchesOffAnLedLeftOn) {
  auto state = std::make_shared<FakeLights::State>();
  SafeLights lights(std::make_unique<FakeLights>(state), 50ms);
  ASSERT_TRUE(lights.turn_on(2));
  const auto deadline = Clock::now() + 2s;
  while (!lights.timed_out() && Clock::now() < deadline)
    std::this_thread::sleep_for(5ms);
  EXPECT_TRUE(lights.timed_out());
  EXPECT_EQ(lit_count(*state), 0);
  // Switching again clears the flag, and a short switch does not trip it.
  ASSERT_TRUE(lights.turn_on(1));
  EXPECT_FALSE(lights.timed_out());
  ASSERT_TRUE(lights.all_off());
  std::this_thread::sleep_for(100ms);
  EXPECT_FALSE(lights.timed_out());
}

TEST(SafeLights, DestructionAndExceptionsLeaveAllOff) {
  auto state = std::make_shared<FakeLights::State>();
  try {
    SafeLights lights(std::make_unique<FakeLights>(state), 5s);
    ASSERT_TRUE(lights.turn_on(1));
    throw std::runtime_error("something went wrong mid-scan");
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(lit_count(*state), 0);
}

TEST(SafeLights, EmergencyOffReachesEveryInstance) {
  auto a = std::make_shared<FakeLights::State>(), b = std::make_shared<FakeLights::State>();
  SafeLights first(std::make_unique<FakeLights>(a), 5s),
      second(std::make_unique<FakeLights>(b), 5s);
  ASSERT_TRUE(first.turn_on(0));
  ASSERT_TRUE(second.turn_on(2));
  emergency_all_off();
  EXPECT_EQ(lit_count(*a), 0);
  EXPECT_EQ(lit_count(*b), 0);
}

}  // namespace
}  // namespace psrig::lights
