#include "psrig/preview/patch_tile.h"

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "psrig/analysis/fabric_measure.h"
#include "psrig/analysis/seamless_tile.h"
#include "psrig/formats/maps_reader.h"

namespace psrig::preview {

namespace fs = std::filesystem;

namespace {

// A tile psrig tile wrote: its maps, and tile.json for the physical size.
std::optional<PatchTile> stored_tile(const SwatchMaps& maps) {
  const fs::path dir = maps.directory / formats::tile_files::kDirectory;
  std::ifstream in(dir / formats::tile_files::kDescription);
  if (!in) return std::nullopt;
  const auto doc = nlohmann::json::parse(in, nullptr, false);
  if (!doc.is_object() || doc.value("format", "") != formats::tile_files::kFormat)
    return std::nullopt;
  auto loaded = load_swatch_maps(dir);
  if (!loaded) return std::nullopt;
  PatchTile tile;
  tile.maps = std::move(*loaded);
  tile.maps.sample_id = maps.sample_id;
  tile.maps.pixel_size_mm =
      doc["pixel_size_mm"].is_number() ? doc["pixel_size_mm"].get<double>() : 0.0;
  if (doc["height_units"].is_string())
    tile.maps.height_units = doc["height_units"].get<std::string>();
  tile.periodic = doc.value("periodic", false);
  if (doc["repeats"].is_array() && doc["repeats"].size() == 2) {
    tile.repeats_u = doc["repeats"][0].get<int>();
    tile.repeats_v = doc["repeats"][1].get<int>();
  }
  tile.source = dir.string();
  return tile;
}

}  // namespace

PatchTile patch_tile(const SwatchMaps& maps) {
  if (auto stored = stored_tile(maps)) return std::move(*stored);
  PatchTile out;
  out.maps = maps;
  std::vector<std::string> warnings;
  auto read = formats::read_maps(maps.directory, warnings);
  if (!read) {
    out.source = "the maps as they are (" + read.error().describe() + ")";
    return out;
  }
  const cv::Mat& height = read->height.empty() ? read->p : read->height;
  const auto lattice = analysis::find_repeat_lattice(height, read->albedo);
  auto tile = analysis::make_seamless_tile(*read, lattice);
  if (!tile) {
    out.source = "the maps as they are (" + tile.error().describe() + ")";
    return out;
  }
  SwatchMaps& m = out.maps;
  cv::cvtColor(tile->maps.albedo, m.albedo, cv::COLOR_BGR2RGB);
  // n = (-p, -q, 1) / |.|, p = dz/dx, q = dz/dy with y up: the scan's axes.
  std::vector<cv::Mat> n = {-tile->maps.p, -tile->maps.q,
                            cv::Mat::ones(tile->maps.p.size(), CV_32F)};
  cv::Mat length;
  cv::magnitude(n[0], n[1], length);
  cv::sqrt(length.mul(length) + 1.0, length);
  for (auto& c : n)
    c /= length;
  cv::merge(n, m.normal);
  m.height = tile->maps.height;
  m.gloss.release();  // the tile has none; the renderer's uniform gloss
  m.alpha.release();
  m.pixel_size_mm = tile->pixel_size_mm.value_or(0.0);
  out.periodic = tile->periodic;
  out.repeats_u = tile->repeats_u;
  out.repeats_v = tile->repeats_v;
  out.source = "cut in memory (psrig tile " + maps.directory.string() + " keeps one)";
  return out;
}

}  // namespace psrig::preview
