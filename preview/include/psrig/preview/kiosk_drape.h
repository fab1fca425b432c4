#pragma once
// The kiosk's second view: the newest scan's knit draping (psrig-preview
// kiosk --drape SCENE). The chart is read off the scan's maps and knitted
// off the render thread, since reading a chart takes up to seconds; the
// kiosk keeps showing the swatch meanwhile, and only the swatch when the
// scan shows no knit (woven, no repeat: said once).

#include <filesystem>
#include <future>
#include <memory>
#include <optional>
#include <string>

#include "psrig/cloth/drape_scene.h"
#include "psrig/preview/drape_cloth.h"

namespace psrig::preview {

struct KioskDrapeOptions {
  cloth::DrapeScene scene = cloth::DrapeScene::hang;
  int stitches = 40, rows = 48;
  bool wait = false;  // knit on the calling thread (headless runs: the same frames every time)
  bool encode_srgb = false;
};

class KioskDrape {
 public:
  explicit KioskDrape(KioskDrapeOptions options) : options_(options) {}

  // A new scan on show: its knit is made (in the background unless
  // `wait`); the one made before is dropped.
  void prepare(const std::filesystem::path& maps);
  // Takes a finished knit; true when the scan on show has one to drape.
  bool ready();
  // The drape from its start; then one frame `dt` seconds on, drawn to the
  // bound framebuffer.
  void restart();
  [[nodiscard]] Status draw(float dt, cv::Size size);

 private:
  struct Made {
    std::filesystem::path maps;
    std::optional<cloth::KnitFabric> fabric;
    std::string why;  // when there is none
  };
  void take(Made made);

  KioskDrapeOptions options_;
  std::optional<std::filesystem::path> wanted_;        // the scan on show
  std::optional<std::filesystem::path> queued_;        // waiting for the one in hand
  std::future<Made> making_;
  std::optional<Made> made_;
  std::optional<cloth::DrapeAnimation> animation_;
  std::optional<DrapeRenderers> renderers_;
  std::filesystem::path scan_maps_;  // whose maps the renderers' far level shows
};

}  // namespace psrig::preview
