#pragma once
// psrigd's exports of a scan (GET /v1/scans/{id}/export/{format}): made from
// the scan's maps on the first request, kept in SCAN_DIR/exports/, served
// from there after; requests for the same export at once make it once.

#include <filesystem>
#include <map>
#include <memory>
#include <mutex>

#include "psrig/base/error.h"
#include "psrig/catalogue/catalogue.h"
#include "psrig/export/export_format.h"

namespace httplib {
struct Request;
struct Response;
}  // namespace httplib

namespace psrig::daemon {

inline constexpr const char* kExportsDirectory = "exports";

class ScanExports {
 public:
  // SCAN_DIR/exports/material.<glb|u3ma> for the maps in `maps_directory`;
  // made when absent. Only single-file formats (glb, u3ma) travel over HTTP.
  [[nodiscard]] Result<std::filesystem::path> get(const std::filesystem::path& scan_directory,
                                                  const std::filesystem::path& maps_directory,
                                                  export_::ExportFormat format);

 private:
  std::mutex mutex_;  // guards making_
  std::map<std::filesystem::path, std::shared_ptr<std::mutex>> making_;
};

// The handler of GET /v1/scans/{id}/export/{format} (matches 1 and 2).
void serve_scan_export(const catalogue::Catalogue& catalogue, ScanExports& exports,
                       const httplib::Request& req, httplib::Response& res);

}  // namespace psrig::daemon
