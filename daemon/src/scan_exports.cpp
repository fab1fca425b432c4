#include "scan_exports.h"

#include <array>
#include <charconv>
#include <fstream>
#include <httplib.h>

#include <nlohmann/json.hpp>

#include "http_answers.h"
#include "psrig/base/log.h"
#include "psrig/export/material_source.h"

namespace psrig::daemon {
namespace fs = std::filesystem;

Result<fs::path> ScanExports::get(const fs::path& scan_directory, const fs::path& maps_directory,
                                  export_::ExportFormat format) {
  const fs::path target =
      scan_directory / kExportsDirectory / ("material." + std::string(export_::to_string(format)));
  std::shared_ptr<std::mutex> lock;
  {
    const std::lock_guard guard(mutex_);
    auto& slot = making_[target];
    if (!slot) slot = std::make_shared<std::mutex>();
    lock = slot;
  }
  // One maker per export; the others wait here and then find it made.
  const std::lock_guard making(*lock);
  // Kept while it is newer than the maps (reprocessing makes it again).
  std::error_code ec;
  std::error_code maps_ec;
  if (fs::is_regular_file(target, ec) &&
      fs::last_write_time(target, ec) >= fs::last_write_time(maps_directory, maps_ec) && !ec &&
      !maps_ec)
    return target;
  auto source = export_::material_for_export(maps_directory);  // its seamless tile
  if (!source) return std::unexpected(source.error());
  fs::create_directories(target.parent_path(), ec);
  if (ec) return std::unexpected(io_error(target.parent_path(), "cannot create: " + ec.message()));
  auto made = export_::export_material(*source, format, target);
  if (!made) return std::unexpected(made.error());
  for (const auto& warning : made->warnings)
    logger("http")->warn("export of {}: {}", maps_directory.string(), warning);
  return target;
}

void serve_scan_export(const catalogue::Catalogue& catalogue, ScanExports& exports,
                       const httplib::Request& req, httplib::Response& res) {
  const auto id = parse_id(req.matches[1]);
  if (!id) return refuse(res, 404, "no such scan");
  const auto format = export_::parse_export_format(std::string(req.matches[2]));
  if (!format || !export_::is_single_file(*format))
    return refuse(res, 404,
                  "no export format named that; ask for glb (glTF 2.0, binary) or u3ma (U3M 1.1 "
                  "archive); the folder formats gltf and u3m are made by psrig export");
  auto entry = catalogue.get(*id);
  if (!entry) return refuse(res, 500, entry.error().describe());
  if (!*entry) return refuse(res, 404, "no scan " + std::to_string(*id));
  if ((*entry)->maps_directory.empty() || (*entry)->scan_directory.empty())
    return refuse(res, 409, "scan " + std::to_string(*id) + " has no maps to export yet");
  auto path = exports.get((*entry)->scan_directory, (*entry)->maps_directory, *format);
  if (!path)
    return refuse(res, path.error().kind == ErrorKind::bad_input ? 409 : 500,
                  path.error().describe());
  send_file(
      req, res, *path,
      *format == export_::ExportFormat::glb ? "model/gltf-binary" : "application/octet-stream",
      "scan " + std::to_string(*id) + "'s export is gone",
      "scan-" + std::to_string(*id) + "." + std::string(export_::to_string(*format)));
}

}  // namespace psrig::daemon
