#include "psrig/preview/display_mode.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>

#include "psrig/base/width_height.h"

namespace psrig::preview {
namespace {

// Within this of the asked refresh counts as the same (59.94 for 60).
constexpr double kRefreshTolerance = 1.0;

bool iequal(std::string_view a, std::string_view b) {
  const auto lower = [](unsigned char c) {
    return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : static_cast<char>(c);
  };
  return std::ranges::equal(a, b, [&](char x, char y) { return lower(x) == lower(y); });
}

template <class T>
bool parse_whole(std::string_view text, T& value) {
  if (text.empty()) return false;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  return error == std::errc{} && end == text.data() + text.size();
}

// "HDMI-A-1 (connected), DSI-1 (disconnected)"
std::string list_connectors(const std::vector<ConnectorInfo>& connectors) {
  std::string text;
  for (const auto& connector : connectors) {
    if (!text.empty()) text += ", ";
    text += connector.name + (connector.connected ? " (connected)" : " (disconnected)");
  }
  return text;
}

// "1920x1080@60Hz (preferred), 1280x720@60Hz", each description once.
std::string list_modes(const std::vector<DisplayMode>& modes) {
  std::vector<std::string> seen;
  std::string text;
  for (const auto& mode : modes) {
    const std::string item = describe_mode(mode) + (mode.preferred ? " (preferred)" : "");
    if (std::ranges::find(seen, item) != seen.end()) continue;
    seen.push_back(item);
    if (!text.empty()) text += ", ";
    text += item;
  }
  return text;
}

Error request_error(std::string message) {
  return bad_input({}, {}, std::move(message));
}

Result<std::size_t> choose_connector(const std::vector<ConnectorInfo>& connectors,
                                     std::string_view wanted) {
  if (connectors.empty()) return std::unexpected(io_error({}, "the device has no connectors"));
  if (wanted.empty()) {
    for (std::size_t i = 0; i < connectors.size(); ++i)
      if (connectors[i].connected) return i;
    return std::unexpected(io_error({},
                                    "no connector is connected (is the display plugged in and "
                                    "powered?); connectors: " +
                                        list_connectors(connectors)));
  }
  for (std::size_t i = 0; i < connectors.size(); ++i) {
    if (!iequal(connectors[i].name, wanted)) continue;
    if (!connectors[i].connected)
      return std::unexpected(io_error(
          {}, "connector \"" + std::string(wanted) +
                  "\" is not connected (is the display plugged in and powered?); connectors: " +
                  list_connectors(connectors)));
    return i;
  }
  return std::unexpected(request_error("connector \"" + std::string(wanted) +
                                       "\" not found; connectors: " + list_connectors(connectors)));
}

bool larger(const DisplayMode& a, const DisplayMode& b) {
  const long area_a = static_cast<long>(a.width) * a.height;
  const long area_b = static_cast<long>(b.width) * b.height;
  return area_a != area_b ? area_a > area_b : a.refresh_hz > b.refresh_hz;
}

}  // namespace

std::string describe_mode(const DisplayMode& mode) {
  char refresh[32];
  std::snprintf(refresh, sizeof refresh, "%.2f", mode.refresh_hz);
  std::string hz = refresh;
  // 60.00 reads as 60, 59.90 as 59.9.
  while (!hz.empty() && hz.back() == '0')
    hz.pop_back();
  if (!hz.empty() && hz.back() == '.') hz.pop_back();
  return std::to_string(mode.width) + "x" + std::to_string(mode.height) + "@" + hz + "Hz";
}

Result<ModeRequest> parse_mode_request(std::string_view text) {
  const auto bad = [&] {
    return std::unexpected(request_error(
        "mode \"" + std::string(text) +
        "\" is not WIDTHxHEIGHT or WIDTHxHEIGHT@HZ (e.g. 1920x1080 or 1920x1080@60)"));
  };
  ModeRequest request;
  std::string_view size = text;
  if (const auto at = text.find('@'); at != std::string_view::npos) {
    size = text.substr(0, at);
    std::string_view refresh = text.substr(at + 1);
    if (refresh.size() > 2 && iequal(refresh.substr(refresh.size() - 2), "hz"))
      refresh.remove_suffix(2);
    double hz = 0;
    if (!parse_whole(refresh, hz) || !std::isfinite(hz) || hz <= 0) return bad();
    request.refresh_hz = hz;
  }
  const auto parsed = parse_width_height(size);
  if (!parsed || parsed->width <= 0 || parsed->height <= 0) return bad();
  request.width = parsed->width;
  request.height = parsed->height;
  return request;
}

Result<ModeChoice> choose_display_mode(const std::vector<ConnectorInfo>& connectors,
                                       std::string_view connector_wanted,
                                       std::string_view mode_wanted) {
  auto connector = choose_connector(connectors, connector_wanted);
  if (!connector) return std::unexpected(connector.error());
  const ConnectorInfo& info = connectors[*connector];
  const auto& modes = info.modes;
  if (modes.empty())
    return std::unexpected(
        io_error({}, "connector " + info.name + " is connected but offers no modes"));

  std::optional<std::size_t> best;
  if (mode_wanted.empty()) {
    for (std::size_t i = 0; i < modes.size() && !best; ++i)
      if (modes[i].preferred) best = i;
    if (!best) {  // no EDID preference: the largest, at its highest refresh
      best = 0;
      for (std::size_t i = 1; i < modes.size(); ++i)
        if (larger(modes[i], modes[*best])) best = i;
    }
    return ModeChoice{*connector, *best};
  }

  auto request = parse_mode_request(mode_wanted);
  if (!request) return std::unexpected(request.error());
  for (std::size_t i = 0; i < modes.size(); ++i) {
    const DisplayMode& mode = modes[i];
    if (mode.width != request->width || mode.height != request->height) continue;
    if (request->refresh_hz) {
      const double off = std::abs(mode.refresh_hz - *request->refresh_hz);
      if (off > kRefreshTolerance) continue;
      if (!best || off < std::abs(modes[*best].refresh_hz - *request->refresh_hz)) best = i;
    } else if (!best || mode.refresh_hz > modes[*best].refresh_hz) {
      best = i;
    }
  }
  if (!best)
    return std::unexpected(request_error("mode \"" + std::string(mode_wanted) +
                                         "\" not offered by " + info.name +
                                         "; modes: " + list_modes(modes)));
  return ModeChoice{*connector, *best};
}

}  // namespace psrig::preview
