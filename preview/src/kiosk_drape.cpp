#include "psrig/preview/kiosk_drape.h"

#include <iostream>

namespace psrig::preview {
namespace {

// The kiosk's camera on the drape, as `psrig-preview drape`'s default.
constexpr double kYawDeg = 20, kPitchDeg = 25;

}  // namespace

void KioskDrape::prepare(const std::filesystem::path& maps) {
  wanted_ = maps;
  animation_.reset();
  const auto make = [stitches = options_.stitches, rows = options_.rows](std::filesystem::path at) {
    Made made{at, std::nullopt, {}};
    auto fabric = drape_fabric(at, stitches, rows);
    if (fabric)
      made.fabric = std::move(*fabric);
    else
      made.why = fabric.error().message;
    return made;
  };
  if (options_.wait) {
    take(make(maps));
    return;
  }
  if (making_.valid()) {  // one knit at a time: this scan's waits for the one in hand
    queued_ = maps;
    return;
  }
  making_ = std::async(std::launch::async, make, maps);
}

void KioskDrape::take(Made made) {
  if (!wanted_ || made.maps != *wanted_) return;  // a scan no longer on show
  if (made.fabric)
    std::cout << "kiosk: draping " << made.maps.string() << std::endl;
  else
    std::cout << "kiosk: no drape for " << made.maps.string() << ": " << made.why << std::endl;
  made_ = std::move(made);
}

bool KioskDrape::ready() {
  if (making_.valid() &&
      making_.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
    take(making_.get());
    if (queued_) {
      const auto next = *queued_;
      queued_.reset();
      prepare(next);
    }
  }
  return made_ && wanted_ && made_->maps == *wanted_ && made_->fabric;
}

void KioskDrape::restart() {
  if (!made_ || !made_->fabric) return;
  animation_.emplace(*made_->fabric, options_.scene);
}

Status KioskDrape::draw(float dt, cv::Size size) {
  if (!animation_) restart();
  if (!animation_) return {};
  // Renderers of its own for each scan: its maps are its drape's far level.
  if (!renderers_ || scan_maps_ != made_->maps) {
    YarnRendererOptions options;
    options.encode_srgb = options_.encode_srgb;
    auto renderers = drape_renderers(options);
    if (!renderers) return std::unexpected(renderers.error());
    renderers_ = std::move(*renderers);
    scan_maps_ = made_->maps;
    if (auto tile = use_scan_maps(*renderers_, made_->maps); !tile)
      std::cout << "kiosk: the drape of " << made_->maps.string()
                << " shows its knit from afar: " << tile.error().message << std::endl;
  }
  animation_->advance(dt);
  draw_drape(*animation_, *renderers_, drape_view(kYawDeg, kPitchDeg), size);
  return {};
}

}  // namespace psrig::preview
