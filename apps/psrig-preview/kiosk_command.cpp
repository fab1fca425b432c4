// psrig-preview kiosk (MAPS_DIR | --catalogue DIR): the newest scan full
// screen with the light orbiting, switching when a new scan lands; with
// --drape SCENE, turn about with the scan's knit draping (kiosk_drape.h).
// Runs until SIGINT/SIGTERM (or --frames); a scan that cannot be shown is
// reported and the kiosk goes on showing the last good one.

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>

#include "command.h"
#include "kiosk_output.h"
#include "psrig/formats/map_encoding.h"
#include "psrig/formats/scan_layout.h"
#include "psrig/preview/clear_frame.h"
#include "psrig/preview/kiosk_drape.h"
#include "psrig/preview/newest_scan.h"
#include "psrig/preview/patch_tile.h"
#include "psrig/preview/scene_motion.h"

namespace psrig::preview::cli {
namespace {

namespace fs = std::filesystem;

struct KioskArgs {
  std::string maps;
  std::string catalogue;
  bool headless = false;
  long frames = 0;  // 0: until a signal
  std::string out_dir;
  std::string size = "1280x720";
  double fps = 30;  // headless: the clock the motion follows
  int poll_ms = 1000;
  int samples = kDefaultSamples;
  KmsArgs kms;
  std::string drape;  // "": the swatch only
  double swatch_seconds = 15, drape_seconds = 15;
  int drape_stitches = 40, drape_rows = 48;
  bool drape_in_background = false;  // headless: as the display does
};

std::atomic<bool> stop_requested{false};

void request_stop(int) {
  stop_requested = true;
}

void stop_on_signals() {
  struct sigaction action {};
  action.sa_handler = request_stop;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

// The scan on show and the one that last failed (not retried until it changes).
struct Shown {
  fs::path maps;
  fs::file_time_type written;
};

std::optional<Shown> identify(const fs::path& maps) {
  std::error_code error;
  const auto written = fs::last_write_time(maps / formats::map_files::kReport, error);
  if (error) return std::nullopt;
  return Shown{maps, written};
}

bool same(const std::optional<Shown>& a, const std::optional<Shown>& b) {
  return a && b && a->maps == b->maps && a->written == b->written;
}

SceneView kiosk_view() {
  SceneView view;
  view.kind = ViewKind::patch;
  view.camera_yaw_deg = 0;
  view.camera_pitch_deg = 30;
  view.light.slant_deg = 50;
  return view;
}

int run_kiosk(const KioskArgs& args) {
  if (args.maps.empty() == args.catalogue.empty())
    return report_error("kiosk",
                        bad_input("", "MAPS_DIR", "give a maps directory or --catalogue DIR"));
  if (args.headless && args.out_dir.empty())
    return report_error("kiosk", bad_input("", "--out-dir", "--headless needs --out-dir DIR"));
  // A path that is not there is a typo, not a scan still to come: say so
  // rather than show an empty screen.
  if (!args.maps.empty() && !fs::is_directory(args.maps))
    return report_error("kiosk", bad_input(args.maps, "MAPS_DIR", "not a directory"));
  if (!args.catalogue.empty() && !fs::is_directory(args.catalogue))
    return report_error("kiosk", bad_input(args.catalogue, "--catalogue", "not a directory"));
  std::optional<cloth::DrapeScene> drape_scene;
  if (!args.drape.empty()) {
    drape_scene = cloth::parse_drape_scene(args.drape);
    if (!drape_scene)
      return report_error("kiosk", bad_input({}, "--drape",
                                             "'" + args.drape +
                                                 "' is not a scene: hang, table, sphere or arm"));
  }
  stop_on_signals();
  auto output = args.headless ? open_headless_output(args.size, args.samples, args.out_dir)
                              : open_kms_output(args.kms, args.samples);
  if (!output) return report_error("kiosk", output.error());
  KioskOutput& screen = **output;
  std::cout << "kiosk: " << screen.describe() << std::endl;

  RendererOptions options = screen.renderer_options();
  std::optional<KioskDrape> drape;
  if (drape_scene)
    drape.emplace(KioskDrapeOptions{*drape_scene, args.drape_stitches, args.drape_rows,
                                    args.headless && !args.drape_in_background,
                                    options.encode_srgb});
  // The swatch shows for swatch_seconds, then (a knit's scan) the drape
  // for drape_seconds, from its start each time.
  bool draping = false;
  double view_since = 0, last = 0;
  std::unique_ptr<SwatchRenderer> renderer;
  std::optional<Shown> shown, failed;
  SceneMotion motion;
  const SceneView base = kiosk_view();
  const auto start = Clock::now();
  double next_poll = 0;
  for (long frame = 0; (args.frames == 0 || frame < args.frames) && !stop_requested; ++frame) {
    const double now = args.headless ? static_cast<double>(frame) / args.fps
                                     : std::chrono::duration<double>(Clock::now() - start).count();
    // Headless frames poll every frame, so a test sees a new scan at once.
    if (args.headless || now >= next_poll) {
      next_poll = now + args.poll_ms / 1000.0;
      const auto newest =
          args.catalogue.empty() ? identify(args.maps) : [&]() -> std::optional<Shown> {
        const auto maps = newest_maps(args.catalogue);
        return maps ? identify(*maps) : std::nullopt;
      }();
      if (newest && !same(newest, shown) && !same(newest, failed)) {
        auto maps = load_swatch_maps(newest->maps);
        if (maps) maps = patch_tile(*maps).maps;  // the patch repeats the seamless tile
        auto next = maps ? SwatchRenderer::create(*maps, options)
                         : Result<std::unique_ptr<SwatchRenderer>>(std::unexpected(maps.error()));
        if (next) {
          renderer = std::move(*next);
          shown = newest;
          motion.kick(now, 90);  // a new scan arrives with a spin
          draping = false;
          view_since = now;
          std::cout << "kiosk: showing " << newest->maps.string() << std::endl;
          if (drape) drape->prepare(newest->maps);
        } else {
          failed = newest;
          std::cout << "kiosk: cannot show " << newest->maps.string() << ": "
                    << next.error().describe() << std::endl;
        }
      }
    }
    const bool can_drape = drape && renderer && drape->ready();
    if (!can_drape) {
      draping = false;
    } else if (now - view_since >= (draping ? args.drape_seconds : args.swatch_seconds)) {
      draping = !draping;
      view_since = now;
      if (draping) drape->restart();
    }
    // A stall (a slow frame, a suspended process) moves the cloth at most
    // a twentieth of a second.
    const auto dt = static_cast<float>(std::clamp(now - last, 0.0, 0.05));
    last = now;
    screen.begin_frame();
    if (draping) {
      if (auto ok = drape->draw(dt, screen.size()); !ok) {
        std::cout << "kiosk: cannot drape: " << ok.error().describe() << std::endl;
        drape.reset();  // the swatch from now on
        draping = false;
      }
    }
    if (!draping && renderer)
      renderer->draw(motion.at(now, base), screen.size());
    else if (!draping)
      clear_frame(options.background, options.encode_srgb, screen.size());  // waiting for a scan
    if (auto ok = screen.end_frame(frame); !ok) return report_error("kiosk", ok.error());
  }
  std::cout << "kiosk: stopped" << std::endl;
  return 0;
}

}  // namespace

Command add_kiosk_command(CLI::App& parent) {
  auto args = std::make_shared<KioskArgs>();
  CLI::App* app = parent.add_subcommand(
      "kiosk", "Show the newest scan full screen (KMS) with the light orbiting");
  app->add_option("maps", args->maps, "Maps directory to show");
  app->add_option("--catalogue", args->catalogue,
                  "Directory of scans: show the newest, switch when a new one lands");
  app->add_flag("--headless", args->headless, "Draw offscreen and write PNG frames (tests)");
  app->add_option("--frames", args->frames, "Stop after this many frames (0: run until a signal)")
      ->check(psrig::cli::non_negative_number())
      ->capture_default_str();
  app->add_option("--out-dir", args->out_dir, "Headless: where the frames go (frame_NNNNNN.png)");
  app->add_option("--size", args->size, "Headless: frame size WxH")->capture_default_str();
  app->add_option("--fps", args->fps, "Headless: frames per second of the motion's clock")
      ->check(psrig::cli::positive_number())
      ->capture_default_str();
  app->add_option("--poll-ms", args->poll_ms, "How often to look for a new scan")
      ->check(psrig::cli::positive_number())
      ->capture_default_str();
  app->add_option("--drape", args->drape,
                  "Turn about with the scan's knit draping: hang, table, sphere or arm (knitted "
                  "scans: the chart read off the maps, at their gauge, in their colours)");
  app->add_option("--swatch-seconds", args->swatch_seconds, "With --drape: how long the swatch shows")
      ->check(psrig::cli::positive_number())
      ->capture_default_str();
  app->add_option("--drape-seconds", args->drape_seconds, "With --drape: how long the drape shows")
      ->check(psrig::cli::positive_number())
      ->capture_default_str();
  app->add_option("--drape-stitches", args->drape_stitches, "With --drape: stitches per course")
      ->check(CLI::Range(2, 400))
      ->capture_default_str();
  app->add_option("--drape-rows", args->drape_rows, "With --drape: courses")
      ->check(CLI::Range(2, 400))
      ->capture_default_str();
  app->add_flag("--drape-in-background", args->drape_in_background,
                "Headless with --drape: read and knit each scan's drape in the background, as "
                "on the display (the frames then depend on timing; by default a headless run "
                "waits for it)");
  add_samples_option(*app, args->samples);
  add_kms_options(*app, args->kms);
  return {app, [args] { return run_kiosk(*args); }};
}

}  // namespace psrig::preview::cli
