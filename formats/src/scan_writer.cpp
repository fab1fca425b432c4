#include "psrig/formats/scan_writer.h"

#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "psrig/base/parallel.h"
#include "psrig/formats/atomic_directory.h"
#include "psrig/formats/image_io.h"
#include "psrig/formats/scan_layout.h"

namespace psrig::formats {
namespace {

using formats::Scan;
namespace files = formats::scan_files;
namespace fs = std::filesystem;

nlohmann::json intensity_json(const ScanLight& light) {
  const cv::Vec3d& bgr = light.intensity_bgr;
  if (!light.intensity_is_rgb && bgr[0] == bgr[1] && bgr[1] == bgr[2]) return bgr[0];
  return nlohmann::json::array({bgr[2], bgr[1], bgr[0]});
}

// One image to write, and the name scan.json gives it.
struct ImageFile {
  std::string name;
  const cv::Mat* image;
  bool vector_exr = false;  // (x, y, z) stored as R, G, B
};

std::vector<ImageFile> image_files(const Scan& scan) {
  std::vector<ImageFile> files;
  for (std::size_t k = 0; k < scan.frames.size(); ++k)
    files.push_back(
        {files::led_frame(static_cast<int>(k), scan.frames[k].depth()), &scan.frames[k]});
  if (!scan.dark.empty()) files.push_back({files::dark_frame(scan.dark.depth()), &scan.dark});
  if (!scan.mask.empty()) files.push_back({files::kMask, &scan.mask});
  for (std::size_t k = 0; k < scan.flats.size(); ++k)
    files.push_back(
        {files::flat_frame(static_cast<int>(k), scan.flats[k].depth()), &scan.flats[k]});
  if (!scan.ground_truth_normal.empty())
    files.push_back({files::kGroundTruthNormal, &scan.ground_truth_normal, true});
  if (!scan.ground_truth_height.empty())
    files.push_back({files::kGroundTruthHeight, &scan.ground_truth_height});
  return files;
}

}  // namespace

nlohmann::json scan_json(const Scan& scan) {
  const auto& d = scan.description;
  nlohmann::json doc = d.document.is_object() ? d.document : nlohmann::json::object();
  doc["format"] = kScanFormat;
  nlohmann::json sample = doc.contains("sample") && doc["sample"].is_object()
                              ? doc["sample"]
                              : nlohmann::json::object();
  sample["id"] = d.sample_id;
  sample["description"] = d.sample_description;
  doc["sample"] = sample;
  doc["encoding"] = d.encoding == Encoding::srgb ? "srgb" : "linear";
  doc["black_level"] = d.black_level;
  doc["white_level"] = scan.white_level > 0 ? nlohmann::json(scan.white_level)
                       : d.white_level      ? nlohmann::json(*d.white_level)
                                       : nlohmann::json();  // unknown: the reader takes full scale
  doc["dark"] =
      scan.dark.empty() ? nlohmann::json() : nlohmann::json(files::dark_frame(scan.dark.depth()));
  doc["mask"] = scan.mask.empty() ? nlohmann::json() : nlohmann::json(files::kMask);
  if (scan.flats.empty()) {
    doc.erase("flats");
  } else {
    nlohmann::json flats = nlohmann::json::array();
    for (std::size_t k = 0; k < scan.flats.size(); ++k)
      flats.push_back(files::flat_frame(static_cast<int>(k), scan.flats[k].depth()));
    doc["flats"] = flats;
  }
  nlohmann::json lights = nlohmann::json::array();
  for (std::size_t k = 0; k < d.lights.size(); ++k) {
    const auto& light = d.lights[k];
    lights.push_back({{"image", files::led_frame(static_cast<int>(k), scan.frames[k].depth())},
                      {"direction", {light.direction[0], light.direction[1], light.direction[2]}},
                      {"intensity", intensity_json(light)}});
    if (light.position_mm)
      lights.back()["position_mm"] = {(*light.position_mm)[0], (*light.position_mm)[1],
                                      (*light.position_mm)[2]};
  }
  doc["lights"] = lights;
  doc["pixel_size_mm"] = d.pixel_size_mm ? nlohmann::json(*d.pixel_size_mm) : nlohmann::json();
  if (d.principal_point_px)
    doc["principal_point_px"] = {d.principal_point_px->x, d.principal_point_px->y};
  if (!scan.ground_truth_normal.empty() || !scan.ground_truth_height.empty()) {
    // Other truths the document carries (the simulator's fabric gauge) stay.
    nlohmann::json truth = doc.contains("ground_truth") && doc["ground_truth"].is_object()
                               ? doc["ground_truth"]
                               : nlohmann::json::object();
    if (!scan.ground_truth_normal.empty()) truth["normal"] = files::kGroundTruthNormal;
    if (!scan.ground_truth_height.empty()) truth["height"] = files::kGroundTruthHeight;
    doc["ground_truth"] = truth;
  } else {
    doc.erase("ground_truth");
  }
  return doc;
}

namespace {

Status write_scan_unguarded(const Scan& scan, const fs::path& directory,
                            const StorageOptions& storage) {
  if (scan.frames.size() != scan.description.lights.size() || scan.frames.size() < 3)
    return std::unexpected(internal_error("write_scan: need one frame per light, at least three"));
  std::error_code ec;
  if (fs::exists(directory, ec))
    return std::unexpected(bad_input(directory, "", "already exists; a scan is never overwritten"));
  auto staging = AtomicDirectory::create(directory);
  if (!staging) return std::unexpected(staging.error());

  const auto files = image_files(scan);
  std::vector<std::optional<Error>> errors(files.size());
  psrig::parallel_chunks(static_cast<int>(files.size()), 1, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      const fs::path path = staging->path() / files[i].name;
      auto written =
          files[i].vector_exr
              ? write_vector_exr(path, *files[i].image)
              : write_image(path, *files[i].image, png_params(storage.png_level));
      if (!written) errors[i] = written.error();
    }
  });
  for (const auto& error : errors)
    if (error) return std::unexpected(*error);

  const fs::path json_path = staging->path() / files::kDescription;
  std::ofstream description(json_path);
  description << scan_json(scan).dump(2) << '\n';
  description.close();
  if (!description) return std::unexpected(io_error(json_path, "cannot write"));
  return staging->commit(AtomicDirectory::Existing::refuse, true);
}

}  // namespace

Status write_scan(const Scan& scan, const fs::path& directory,
                  const StorageOptions& storage) {
  if (storage.png_level < 0 || storage.png_level > 9)
    return std::unexpected(internal_error("write_scan: PNG level outside 0-9"));
  try {
    return write_scan_unguarded(scan, directory, storage);
  } catch (const std::exception& e) {  // out of memory, or a library throwing where it should not
    return std::unexpected(
        internal_error(directory.string() + ": writing the scan failed: " + e.what()));
  }
}

}  // namespace psrig::formats
