#pragma once
// One `psrig-preview` subcommand, and what the subcommands share: frame
// size parsing, the view and light options, and error reporting.

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>

#include "psrig/base/cli_command.h"
#include "psrig/preview/egl_context.h"
#include "psrig/preview/offscreen_target.h"
#include "psrig/preview/scan_cloth.h"
#include "psrig/preview/scene_view.h"
#include "psrig/preview/swatch_renderer.h"
#include "psrig/preview/yarn_renderer.h"

namespace psrig::preview::cli {

using psrig::cli::Command;

Command add_render_command(CLI::App& parent);
Command add_kiosk_command(CLI::App& parent);
Command add_bench_command(CLI::App& parent);
Command add_knit_command(CLI::App& parent);
Command add_drape_command(CLI::App& parent);

// The options that place the light and the view (render, bench).
struct ViewArgs {
  std::string view = "patch";
  std::string light = "directional";
  double light_tilt = 45;
  double light_slant = 45;
  double yaw = 0;
  double pitch = 0;
  bool no_light_sphere = false;
};
void add_view_options(CLI::App& app, ViewArgs& args);
[[nodiscard]] SceneView scene_view(const ViewArgs& args);

// What the headless commands draw with: a surfaceless GLES context and an
// sRGB offscreen target (destroyed first, while the context lives).
struct HeadlessCanvas {
  std::unique_ptr<EglContext> context;
  std::unique_ptr<OffscreenTarget> target;
};
[[nodiscard]] Result<HeadlessCanvas> open_headless_canvas(cv::Size size, int samples);

// load_swatch_maps and read_scan_cloth for a directory the user named:
// given a scan directory instead of its maps, the error says which
// directory was meant (with_scan_directory_hint adds that to any error
// reading maps).
[[nodiscard]] Result<SwatchMaps> load_maps_argument(const std::filesystem::path& directory);
[[nodiscard]] Result<ScanCloth> read_scan_cloth_argument(const std::filesystem::path& directory);
[[nodiscard]] Error with_scan_directory_hint(Error error, const std::filesystem::path& directory);

// "1920x1080" -> the size; errors name the option.
[[nodiscard]] Result<cv::Size> parse_size(const std::string& text, const std::string& option);

// The renderer's defaults for the current context: anisotropic filtering
// where it offers GL_EXT_texture_filter_anisotropic.
[[nodiscard]] RendererOptions renderer_options(bool offers_anisotropy);
[[nodiscard]] inline RendererOptions renderer_options(const EglContext& context) {
  return renderer_options(context.has_extension("GL_EXT_texture_filter_anisotropic"));
}

// Prints "psrig-preview COMMAND: error: ..." to stderr and returns the exit code.
inline int report_error(const std::string& command, const Error& error) {
  return psrig::cli::report_error("psrig-preview", command, error);
}

// The multisampling the preview draws with unless told otherwise.
inline constexpr int kDefaultSamples = 4;

// The commands time their frames on this clock, in milliseconds.
using Clock = std::chrono::steady_clock;
inline double milliseconds(Clock::duration duration) {
  return std::chrono::duration<double, std::milli>(duration).count();
}
// --samples, 0 (off) to 16, for every command that draws.
void add_samples_option(CLI::App& app, int& samples);
// --lod auto|near|far, for the commands that draw yarns, and the level it names.
void add_lod_option(CLI::App& app, std::string& lod);
[[nodiscard]] YarnLevel yarn_level(const std::string& lod);

}  // namespace psrig::preview::cli
