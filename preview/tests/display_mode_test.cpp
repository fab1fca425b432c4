// The kiosk's choice of connector and mode, over connector lists made by
// hand: the rules, and errors that name what was asked and what exists.

#include "psrig/preview/display_mode.h"

#include <gtest/gtest.h>

namespace psrig::preview {
namespace {

// A monitor on HDMI whose EDID prefers 1080p60, and a panel with nothing on it.
std::vector<ConnectorInfo> hdmi_monitor_and_dsi_panel() {
  ConnectorInfo dsi{31, "DSI-1", false, {}};
  ConnectorInfo hdmi{42,
                     "HDMI-A-1",
                     true,
                     {{3840, 2160, 30.0, false, "3840x2160"},
                      {1920, 1080, 60.0, true, "1920x1080"},
                      {1920, 1080, 59.94, false, "1920x1080"},
                      {1920, 1080, 50.0, false, "1920x1080"},
                      {1280, 720, 50.0, false, "1280x720"},
                      {1280, 720, 60.0, false, "1280x720"}}};
  return {dsi, hdmi};
}

const DisplayMode& chosen(const std::vector<ConnectorInfo>& connectors, const ModeChoice& choice) {
  return connectors.at(choice.connector).modes.at(choice.mode);
}

TEST(DisplayMode, NoConnectorAskedTakesTheFirstConnected) {
  const auto connectors = hdmi_monitor_and_dsi_panel();
  auto choice = choose_display_mode(connectors, "", "");
  ASSERT_TRUE(choice) << choice.error().describe();
  EXPECT_EQ(choice->connector, 1u);
}

TEST(DisplayMode, ConnectorNamedCaseInsensitively) {
  const auto connectors = hdmi_monitor_and_dsi_panel();
  for (const char* name : {"HDMI-A-1", "hdmi-a-1", "Hdmi-A-1"}) {
    auto choice = choose_display_mode(connectors, name, "");
    ASSERT_TRUE(choice) << name << ": " << choice.error().describe();
    EXPECT_EQ(choice->connector, 1u) << name;
  }
}

TEST(DisplayMode, UnknownConnectorNamesItAndListsWhatExists) {
  const auto connectors = hdmi_monitor_and_dsi_panel();
  auto choice = choose_display_mode(connectors, "HDMI-A-2", "");
  ASSERT_FALSE(choice);
  EXPECT_EQ(choice.error().kind, ErrorKind::bad_input);
  EXPECT_EQ(choice.error().message,
            "connector \"HDMI-A-2\" not found; connectors: DSI-1 (disconnected), HDMI-A-1 "
            "(connected)");
}

TEST(DisplayMode, DisconnectedConnectorIsAnErrorSayingSo) {
  const auto connectors = hdmi_monitor_and_dsi_panel();
  auto choice = choose_display_mode(connectors, "dsi-1", "");
  ASSERT_FALSE(choice);
  const std::string& message = choice.error().message;
  EXPECT_NE(message.find("connector \"dsi-1\" is not connected"), std::string::npos) << message;
  EXPECT_NE(message.find("connectors: DSI-1 (disconnected), HDMI-A-1 (connected)"),
            std::string::npos)
      << message;
}

TEST(DisplayMode, NothingConnectedIsAnErrorListingTheConnectors) {
  auto connectors = hdmi_monitor_and_dsi_panel();
  connectors[1].connected = false;
  auto choice = choose_display_mode(connectors, "", "");
  ASSERT_FALSE(choice);
  EXPECT_EQ(choice.error().message,
            "no connector is connected (is the display plugged in and powered?); connectors: "
            "DSI-1 (disconnected), HDMI-A-1 (disconnected)");
}

TEST(DisplayMode, NoConnectorsAtAllIsAnError) {
  auto choice = choose_display_mode({}, "", "");
  ASSERT_FALSE(choice);
  EXPECT_NE(choice.error().message.find("no connectors"), std::string::npos)
      << choice.error().message;
}

TEST(DisplayMode, ConnectedWithoutModesIsAnErrorNamingTheConnector) {
  const std::vector<ConnectorInfo> connectors{{7, "DP-1", true, {}}};
  auto choice = choose_display_mode(connectors, "", "");
  ASSERT_FALSE(choice);
  EXPECT_EQ(choice.error().message, "connector DP-1 is connected but offers no modes");
}

TEST(DisplayMode, NoModeAskedTakesThePreferredOverTheLargest) {
  const auto connectors = hdmi_monitor_and_dsi_panel();
  auto choice = choose_display_mode(connectors, "", "");
  ASSERT_TRUE(choice) << choice.error().describe();
  EXPECT_EQ(choice->mode, 1u);
  EXPECT_EQ(describe_mode(chosen(connectors, *choice)), "1920x1080@60Hz");
}

TEST(DisplayMode, NoModeAskedAndNonePreferredTakesTheLargestAtItsHighestRefresh) {
  const std::vector<ConnectorInfo> connectors{{1,
                                               "DSI-1",
                                               true,
                                               {{800, 480, 60.0, false, "800x480"},
                                                {1280, 800, 50.0, false, "1280x800"},
                                                {1280, 800, 60.0, false, "1280x800"},
                                                {1024, 768, 75.0, false, "1024x768"}}}};
  auto choice = choose_display_mode(connectors, "", "");
  ASSERT_TRUE(choice) << choice.error().describe();
  EXPECT_EQ(choice->mode, 2u);
}

TEST(DisplayMode, SizeAskedTakesItsHighestRefresh) {
  const auto connectors = hdmi_monitor_and_dsi_panel();
  auto hd = choose_display_mode(connectors, "", "1280x720");
  ASSERT_TRUE(hd) << hd.error().describe();
  EXPECT_EQ(describe_mode(chosen(connectors, *hd)), "1280x720@60Hz");
  auto full_hd = choose_display_mode(connectors, "HDMI-A-1", "1920x1080");
  ASSERT_TRUE(full_hd) << full_hd.error().describe();
  EXPECT_EQ(full_hd->mode, 1u);
}

TEST(DisplayMode, SizeAndRefreshAskedTakesTheNearestWithinOneHertz) {
  const auto connectors = hdmi_monitor_and_dsi_panel();
  const std::pair<const char*, const char*> cases[] = {
      {"1920x1080@60", "1920x1080@60Hz"},    {"1920x1080@59.94", "1920x1080@59.94Hz"},
      {"1920x1080@59", "1920x1080@59.94Hz"}, {"1920x1080@50.9", "1920x1080@50Hz"},
      {"3840x2160@30", "3840x2160@30Hz"},    {"1920x1080@60Hz", "1920x1080@60Hz"},
  };
  for (const auto& [asked, expected] : cases) {
    auto choice = choose_display_mode(connectors, "", asked);
    ASSERT_TRUE(choice) << asked << ": " << choice.error().describe();
    EXPECT_EQ(describe_mode(chosen(connectors, *choice)), expected) << asked;
  }
}

TEST(DisplayMode, ModeNotOfferedNamesItAndListsTheModes) {
  const auto connectors = hdmi_monitor_and_dsi_panel();
  const std::string modes =
      "modes: 3840x2160@30Hz, 1920x1080@60Hz (preferred), 1920x1080@59.94Hz, 1920x1080@50Hz, "
      "1280x720@50Hz, 1280x720@60Hz";
  for (const char* asked : {"1024x768", "1920x1080@75", "1920x1080@48.9", "3840x2160@60"}) {
    auto choice = choose_display_mode(connectors, "", asked);
    ASSERT_FALSE(choice) << asked;
    EXPECT_EQ(choice.error().kind, ErrorKind::bad_input);
    EXPECT_EQ(choice.error().message,
              "mode \"" + std::string(asked) + "\" not offered by HDMI-A-1; " + modes);
  }
}

TEST(DisplayMode, ModeListNamesEachModeOnce) {
  std::vector<ConnectorInfo> connectors{{1,
                                         "HDMI-A-1",
                                         true,
                                         {{1920, 1080, 60.0, true, "1920x1080"},
                                          {1920, 1080, 60.0, false, "1920x1080"},
                                          {1920, 1080, 60.0, false, "1920x1080"}}}};
  auto choice = choose_display_mode(connectors, "", "640x480");
  ASSERT_FALSE(choice);
  EXPECT_EQ(choice.error().message,
            "mode \"640x480\" not offered by HDMI-A-1; modes: 1920x1080@60Hz (preferred), "
            "1920x1080@60Hz");
}

TEST(DisplayMode, ModeTextParses) {
  auto plain = parse_mode_request("1920x1080");
  ASSERT_TRUE(plain) << plain.error().describe();
  EXPECT_EQ(plain->width, 1920);
  EXPECT_EQ(plain->height, 1080);
  EXPECT_FALSE(plain->refresh_hz.has_value());

  for (const char* text : {"1280X720@59.94", "1280x720@59.94Hz", "1280x720@59.94hz"}) {
    auto request = parse_mode_request(text);
    ASSERT_TRUE(request) << text << ": " << request.error().describe();
    EXPECT_EQ(request->width, 1280) << text;
    EXPECT_EQ(request->height, 720) << text;
    ASSERT_TRUE(request->refresh_hz.has_value()) << text;
    EXPECT_DOUBLE_EQ(*request->refresh_hz, 59.94) << text;
  }
}

TEST(DisplayMode, BadModeTextIsAClearErrorQuotingIt) {
  for (const char* text :
       {"big", "1920", "1920x", "x1080", "1920x1080@", "1920x1080@fast", "-1920x1080", "0x1080",
        "1920x1080@0", "1920x1080@-60", "1920x1080@inf", "1920x1080@nan", "1920 x 1080",
        "1920x1080x3", "1920x1080@60@60", "1920x1080@Hz"}) {
    auto request = parse_mode_request(text);
    ASSERT_FALSE(request) << text;
    EXPECT_EQ(request.error().kind, ErrorKind::bad_input) << text;
    EXPECT_EQ(request.error().message,
              "mode \"" + std::string(text) +
                  "\" is not WIDTHxHEIGHT or WIDTHxHEIGHT@HZ (e.g. 1920x1080 or 1920x1080@60)");
  }
}

TEST(DisplayMode, BadModeTextIsReportedByTheChoiceToo) {
  const auto connectors = hdmi_monitor_and_dsi_panel();
  auto choice = choose_display_mode(connectors, "", "fullhd");
  ASSERT_FALSE(choice);
  EXPECT_NE(choice.error().message.find("mode \"fullhd\" is not WIDTHxHEIGHT"), std::string::npos)
      << choice.error().message;
}

TEST(DisplayMode, DescribesModesWithoutTrailingZeros) {
  EXPECT_EQ(describe_mode({1920, 1080, 60.0, true, "1920x1080"}), "1920x1080@60Hz");
  EXPECT_EQ(describe_mode({1920, 1080, 59.9400599, false, "1920x1080"}), "1920x1080@59.94Hz");
  EXPECT_EQ(describe_mode({720, 576, 49.9, false, "720x576i"}), "720x576@49.9Hz");
}

}  // namespace
}  // namespace psrig::preview
