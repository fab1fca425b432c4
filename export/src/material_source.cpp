#include "psrig/export/material_source.h"

#include <cstring>
#include <fstream>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "psrig/analysis/seamless_tile.h"
#include "psrig/formats/scan_layout.h"
#include "psrig/formats/scratch_directory.h"

namespace psrig::export_ {
namespace {

namespace fs = std::filesystem;
namespace map_files = formats::map_files;
using nlohmann::json;

Result<json> read_json(const fs::path& file) {
  std::ifstream in(file);
  if (!in) return std::unexpected(bad_input(file, "", "cannot open"));
  json doc = json::parse(in, nullptr, false);
  if (doc.is_discarded() || !doc.is_object())
    return std::unexpected(bad_input(file, "", "not a JSON object; remake it"));
  return doc;
}

// A positive number at `key`, null/absent as nothing, anything else an error.
Result<std::optional<double>> optional_length(const json& doc, const fs::path& file,
                                              const std::string& key) {
  if (!doc.contains(key) || doc[key].is_null()) return std::optional<double>();
  if (!doc[key].is_number() || !(doc[key].get<double>() > 0))
    return std::unexpected(
        bad_input(file, key, "expected a positive number of millimetres or null"));
  return std::optional<double>(doc[key].get<double>());
}

// The image's size: a PNG's from its header (IHDR), without decoding it.
Result<cv::Size> image_size(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  unsigned char head[24] = {};
  if (in.read(reinterpret_cast<char*>(head), sizeof head) &&
      std::memcmp(head, "\x89PNG\r\n\x1a\n", 8) == 0 && std::memcmp(head + 12, "IHDR", 4) == 0) {
    const auto be32 = [&](int at) {
      return static_cast<int>((head[at] << 24) | (head[at + 1] << 16) | (head[at + 2] << 8) |
                              head[at + 3]);
    };
    if (be32(16) > 0 && be32(20) > 0) return cv::Size(be32(16), be32(20));
  }
  const cv::Mat image = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
  if (image.empty())
    return std::unexpected(bad_input(file, "", "cannot read the image; remake the maps"));
  return image.size();
}

std::string sample_id_of(const json& doc) {
  if (doc.contains("sample") && doc["sample"].is_object() && doc["sample"].contains("id") &&
      doc["sample"]["id"].is_string())
    return doc["sample"]["id"].get<std::string>();
  return {};
}
std::string sample_description_of(const json& doc) {
  if (doc.contains("sample") && doc["sample"].is_object() &&
      doc["sample"].contains("description") && doc["sample"]["description"].is_string())
    return doc["sample"]["description"].get<std::string>();
  return {};
}
// When the frames were taken: scan.json's capture.started.
std::string scan_time_of(const json& scan) {
  if (scan.contains("capture") && scan["capture"].is_object() &&
      scan["capture"].contains("started") && scan["capture"]["started"].is_string())
    return scan["capture"]["started"].get<std::string>();
  return {};
}

// From a maps directory: report.json (pixel size, sample, height range) and
// the scan.json of the scan it was made from (its time).
Status read_maps_facts(MaterialSource& source) {
  const fs::path report_file = source.directory / map_files::kReport;
  std::error_code ec;
  if (!fs::exists(report_file, ec)) {
    source.warnings.push_back(report_file.string() +
                              " is missing: no pixel size, sample or height range is known "
                              "(reprocess the scan with psrig process to restore it)");
    return {};
  }
  auto report = read_json(report_file);
  if (!report) return std::unexpected(report.error());
  const json inputs = report->value("inputs", json::object());
  if (inputs.is_object()) {
    auto pixel = optional_length(inputs, report_file, "pixel_size_mm");
    if (!pixel)
      return std::unexpected(bad_input(report_file, "inputs.pixel_size_mm", pixel.error().message));
    source.pixel_size_mm = *pixel;
    source.sample_id = sample_id_of(inputs);
    source.sample_description = sample_description_of(inputs);
    if (inputs.contains("capture") && inputs["capture"].is_object())
      source.scan_time = scan_time_of(json{{"capture", inputs["capture"]}});
  }
  const json height = report->value("height", json());
  if (height.is_object() && height.contains("png_range") && height["png_range"].is_array() &&
      height["png_range"].size() == 2 && height["png_range"][0].is_number() &&
      height["png_range"][1].is_number()) {
    source.height_png_range = {height["png_range"][0].get<double>(),
                               height["png_range"][1].get<double>()};
    if (height.contains("units") && height["units"].is_string())
      source.height_units = height["units"].get<std::string>();
  }
  // The scan's own description, when the maps sit in it (SCAN_DIR/maps).
  const fs::path scan_file = source.directory.parent_path() / formats::scan_files::kDescription;
  if (source.scan_time.empty() && fs::exists(scan_file, ec)) {
    if (auto scan = read_json(scan_file)) {
      source.scan_time = scan_time_of(*scan);
      if (source.sample_id.empty()) source.sample_id = sample_id_of(*scan);
    }
  }
  return {};
}

Status read_tile_facts(MaterialSource& source, const fs::path& tile_file) {
  auto tile = read_json(tile_file);
  if (!tile) return std::unexpected(tile.error());
  if (!tile->contains("format") || (*tile)["format"] != formats::tile_files::kFormat)
    return std::unexpected(bad_input(tile_file, "format",
                                     std::string("expected \"") + formats::tile_files::kFormat +
                                         "\"; remake the tile with psrig tile"));
  auto pixel = optional_length(*tile, tile_file, "pixel_size_mm");
  if (!pixel) return std::unexpected(pixel.error());
  source.pixel_size_mm = *pixel;
  if (*pixel) {
    for (auto [key, size] : {std::pair{"width_mm", &source.tile_width_mm},
                             std::pair{"height_mm", &source.tile_height_mm}}) {
      auto length = optional_length(*tile, tile_file, key);
      if (!length) return std::unexpected(length.error());
      *size = *length;
    }
  }
  source.tile = true;
  source.sample_id = sample_id_of(*tile);
  source.sample_description = sample_description_of(*tile);
  if (tile->contains("scan_time") && (*tile)["scan_time"].is_string())
    source.scan_time = (*tile)["scan_time"].get<std::string>();
  return {};
}

}  // namespace

Result<MaterialSource> material_source_from(const fs::path& directory) {
  std::error_code ec;
  if (!fs::is_directory(directory, ec))
    return std::unexpected(bad_input(directory, "MAPS_DIR",
                                     fs::exists(directory, ec)
                                         ? "not a directory; give a maps or tile directory"
                                         : "no such directory; give a maps or tile directory"));
  MaterialSource source;
  source.directory = directory;
  const auto need = [&](const char* name) -> Result<fs::path> {
    const fs::path file = directory / name;
    if (!fs::is_regular_file(file, ec))
      return std::unexpected(bad_input(file, "MAPS_DIR",
                                       "is missing; an export needs the albedo and normal maps "
                                       "(psrig process writes them)"));
    return file;
  };
  auto albedo = need(map_files::kAlbedoPng);
  if (!albedo) return std::unexpected(albedo.error());
  auto normal = need(map_files::kNormalPng);
  if (!normal) return std::unexpected(normal.error());
  source.albedo = *albedo;
  source.normal = *normal;
  if (fs::is_regular_file(directory / map_files::kHeightExr, ec))
    source.height_exr = directory / map_files::kHeightExr;
  if (fs::is_regular_file(directory / map_files::kHeightPng, ec))
    source.height_png = directory / map_files::kHeightPng;

  const fs::path tile_file = directory / formats::tile_files::kDescription;
  if (auto ok =
          fs::exists(tile_file, ec) ? read_tile_facts(source, tile_file) : read_maps_facts(source);
      !ok)
    return std::unexpected(ok.error());

  auto size = image_size(source.albedo);
  if (!size) return std::unexpected(size.error());
  auto normal_size = image_size(source.normal);
  if (!normal_size) return std::unexpected(normal_size.error());
  if (*size != *normal_size)
    return std::unexpected(
        bad_input(source.normal, "MAPS_DIR", "is not the albedo's size; remake the maps"));
  source.width_px = size->width;
  source.height_px = size->height;
  if (!source.pixel_size_mm) {
    source.height_units = "px";
    source.warnings.push_back(
        "no pixel size (pixel_size_mm) in " +
        (source.tile ? (directory / formats::tile_files::kDescription).string()
                     : (directory / map_files::kReport).string()) +
        ": the export is in pixels, one pixel written as 1 mm; calibrate the rig's scale "
        "(psrig calibrate scale) for real sizes");
  }
  if (!source.has_height())
    source.warnings.push_back(
        "no height map (height.exr, height.png): the export has no "
        "displacement");
  return source;
}

namespace {

// The maps' tile cut now for this export alone, into a scratch directory
// the source keeps until it goes: the maps directory is only read.
Result<MaterialSource> cut_for_this_export(const fs::path& maps_directory,
                                           std::vector<std::string>& warnings) {
  auto maps = formats::read_maps(maps_directory, warnings);
  if (!maps) return std::unexpected(maps.error());
  auto tile = analysis::cut_tile(*maps, {}, warnings);
  if (!tile) return std::unexpected(tile.error());
  auto scratch = formats::ScratchDirectory::create("tile");
  if (!scratch) return std::unexpected(scratch.error());
  const fs::path directory = scratch->path() / formats::tile_files::kDirectory;
  if (auto ok = analysis::write_tile(*tile, directory); !ok) return std::unexpected(ok.error());
  auto source = material_source_from(directory);
  if (source)
    source->scratch = std::make_shared<const formats::ScratchDirectory>(std::move(*scratch));
  return source;
}

}  // namespace

Result<MaterialSource> material_for_export(const fs::path& directory, bool whole_scan) {
  std::error_code ec;
  if (whole_scan || fs::is_regular_file(directory / formats::tile_files::kDescription, ec) ||
      !fs::is_directory(directory, ec))
    return material_source_from(directory);
  if (const auto stored = analysis::stored_tile(directory)) return material_source_from(*stored);
  std::vector<std::string> warnings;
  auto source = cut_for_this_export(directory, warnings);
  if (!source) {
    warnings.push_back("no seamless tile (" + source.error().describe() +
                       "); exporting the whole scan, which shows a seam where it repeats");
    source = material_source_from(directory);
    if (!source) return source;
  }
  source->warnings.insert(source->warnings.begin(), warnings.begin(), warnings.end());
  return source;
}

}  // namespace psrig::export_
