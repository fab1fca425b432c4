#pragma once
// U3M 1.1 out (Vizoo's open material format for textiles; schema and rules in
// ../shared/standards/u3m-1.1/): the .u3m JSON beside its textures, or the
// .u3ma container (a restricted zip) holding them. Every image carries its
// width and height in mm and a DPI that agrees with its pixels; the normal
// map is OpenGL convention, (n + 1) / 2; the displacement is the height map
// with factor and offset that give millimetres back
// (offset + grey / 65535 * factor); colours are sRGB D65.

#include <filesystem>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/export/gltf_export.h"
#include "psrig/export/material_source.h"

namespace psrig::export_ {

struct U3mOptions {
  // .u3ma: one file. Otherwise `out` is a directory made whole or not at
  // all: STEM.u3m, the textures and preview.png.
  bool archive = true;
  // Also normal_directx.png (unreferenced: U3M's normals are OpenGL).
  bool directx_normal = false;
};

inline constexpr const char* kU3mSchemaVersion = "1.1";

// The .u3m document for `source`, its images named albedo.png, normal.png,
// height.png and preview.png (the preview `preview_px` wide and high).
[[nodiscard]] nlohmann::json u3m_document(const MaterialSource& source, double mean_height,
                                          double height_low, double height_high,
                                          const cv::Vec3d& mean_linear_rgb, bool has_height,
                                          cv::Size preview_px);

[[nodiscard]] Result<ExportResult> export_u3m(const MaterialSource& source,
                                              const std::filesystem::path& out,
                                              const U3mOptions& options = {});

}  // namespace psrig::export_
