#include "psrig/formats/maps_reader.h"

#include <fstream>
#include <tuple>

#include <opencv2/imgproc.hpp>

#include "psrig/formats/image_io.h"
#include "psrig/formats/scan_layout.h"

namespace psrig::formats {

namespace fs = std::filesystem;

Result<Maps> read_maps(const fs::path& directory, std::vector<std::string>& warnings) {
  std::error_code ec;
  if (!fs::is_directory(directory, ec))
    return std::unexpected(bad_input(
        directory, "", "not a directory; give a maps directory (psrig process writes one)"));
  Maps maps;
  maps.directory = directory;
  const fs::path report_path = directory / map_files::kReport;
  if (fs::exists(report_path, ec)) {
    std::ifstream in(report_path);
    maps.report = nlohmann::json::parse(in, nullptr, false);
    if (maps.report.is_discarded() || !maps.report.is_object())
      return std::unexpected(bad_input(report_path, "", "is not JSON; reprocess the scan"));
    const auto& inputs = maps.report.value("inputs", nlohmann::json::object());
    if (inputs.contains("pixel_size_mm") && inputs["pixel_size_mm"].is_number())
      maps.pixel_size_mm = inputs["pixel_size_mm"].get<double>();
    const auto& height = maps.report.value("height", nlohmann::json::object());
    if (height.is_object() && height.contains("units") && height["units"].is_string())
      maps.height_units = height["units"].get<std::string>();
    if (inputs.contains("scan") && inputs["scan"].is_string()) {
      std::ifstream scan(fs::path(inputs["scan"].get<std::string>()) / scan_files::kDescription);
      if (scan) {
        maps.scan_document = nlohmann::json::parse(scan, nullptr, false);
        if (maps.scan_document.is_discarded()) maps.scan_document = nullptr;
      }
    }
  } else {
    warnings.push_back(report_path.string() +
                       " is missing: no pixel size or fabric metadata, figures in pixels "
                       "(psrig process writes it)");
  }
  if (!maps.pixel_size_mm && maps.report.is_object())
    warnings.push_back("no pixel_size_mm in " + report_path.string() +
                       ": figures are per pixel and sizes in pixels (set the rig's pixel size, "
                       "psrig calibrate scale)");
  if (maps.height_units == "mm" && !maps.pixel_size_mm) maps.height_units = "px";

  const auto read = [&](const char* name, cv::Mat& into, bool required) -> Status {
    const fs::path file = directory / name;
    if (!fs::exists(file, ec)) {
      if (required)
        return std::unexpected(bad_input(
            file, "", "is missing; the maps directory is incomplete (reprocess the scan)"));
      return {};
    }
    auto image = read_image(file, name);
    if (!image) return std::unexpected(image.error());
    into = *image;
    return {};
  };
  if (auto ok = read(map_files::kAlbedoExr, maps.albedo, true); !ok)
    return std::unexpected(ok.error());
  if (auto ok = read(map_files::kP, maps.p, true); !ok) return std::unexpected(ok.error());
  if (auto ok = read(map_files::kQ, maps.q, true); !ok) return std::unexpected(ok.error());
  if (auto ok = read(map_files::kHeightExr, maps.height, false); !ok)
    return std::unexpected(ok.error());
  if (auto ok = read(map_files::kMask, maps.mask, false); !ok) return std::unexpected(ok.error());
  maps.albedo.convertTo(maps.albedo, CV_32F);
  if (maps.albedo.channels() == 1) cv::cvtColor(maps.albedo, maps.albedo, cv::COLOR_GRAY2BGR);
  maps.p.convertTo(maps.p, CV_32F);
  maps.q.convertTo(maps.q, CV_32F);
  if (!maps.height.empty()) maps.height.convertTo(maps.height, CV_32F);
  if (maps.mask.empty()) maps.mask = cv::Mat(maps.p.size(), CV_8U, cv::Scalar(255));
  const cv::Size size = maps.p.size();
  const auto check = [&](const cv::Mat& m, const char* name, int channels) -> Status {
    if (m.empty()) return {};
    if (m.size() != size || m.channels() != channels)
      return std::unexpected(bad_input(
          directory / name, "", "does not match p.exr's size or channels; reprocess the scan"));
    return {};
  };
  for (const auto& [m, name, ch] :
       {std::tuple{&maps.albedo, map_files::kAlbedoExr, 3}, std::tuple{&maps.q, map_files::kQ, 1},
        std::tuple{&maps.height, map_files::kHeightExr, 1},
        std::tuple{&maps.mask, map_files::kMask, 1}})
    if (auto ok = check(*m, name, ch); !ok) return std::unexpected(ok.error());
  if (maps.p.channels() != 1)
    return std::unexpected(bad_input(directory / map_files::kP, "", "expected one channel"));
  return maps;
}

}  // namespace psrig::formats
