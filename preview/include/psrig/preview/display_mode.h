#pragma once
// Which connector and which mode the kiosk lights up: pure selection over
// what the DRM device reported, so the rules are tested without hardware.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "psrig/base/error.h"

namespace psrig::preview {

struct DisplayMode {
  int width = 0;
  int height = 0;
  double refresh_hz = 0;
  bool preferred = false;  // the display's own choice (from its EDID)
  std::string name;        // the kernel's, e.g. "1920x1080" or "1920x1080i"
};

struct ConnectorInfo {
  uint32_t id = 0;
  std::string name;  // "HDMI-A-1", "DSI-1" as the kernel names them: type name + "-" + type id
  bool connected = false;
  std::vector<DisplayMode> modes;
};

// Indices into the connector list and that connector's modes.
struct ModeChoice {
  std::size_t connector = 0;
  std::size_t mode = 0;
};

// "WxH" or "WxH@R" (R in Hz, fractions allowed, an "Hz" suffix tolerated).
struct ModeRequest {
  int width = 0;
  int height = 0;
  std::optional<double> refresh_hz;  // none: the highest the size offers
};

// The text of a mode option; bad text is a bad_input error quoting it.
[[nodiscard]] Result<ModeRequest> parse_mode_request(std::string_view text);

// connector_wanted "": the first connected connector, else the one named
// (case-insensitive). mode_wanted "": the preferred mode, else the largest;
// "1920x1080": that size at its highest refresh; "1920x1080@60": that size
// with the refresh nearest 60 Hz, within 1 Hz. Errors name what was asked and
// list what exists.
[[nodiscard]] Result<ModeChoice> choose_display_mode(const std::vector<ConnectorInfo>& connectors,
                                                     std::string_view connector_wanted,
                                                     std::string_view mode_wanted);

// "1920x1080@60Hz", "1920x1080@59.94Hz".
[[nodiscard]] std::string describe_mode(const DisplayMode& mode);

}  // namespace psrig::preview
