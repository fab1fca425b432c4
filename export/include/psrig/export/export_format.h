#pragma once
// One entry point for every export format (`psrig export`, psrigd).

#include <filesystem>
#include <optional>
#include <string_view>

#include "psrig/base/error.h"
#include "psrig/export/gltf_export.h"
#include "psrig/export/material_source.h"

namespace psrig::export_ {

enum class ExportFormat { glb, gltf, u3m, u3ma };
// "glb" | "gltf" | "u3m" | "u3ma".
[[nodiscard]] std::optional<ExportFormat> parse_export_format(std::string_view name);
[[nodiscard]] std::string_view to_string(ExportFormat format);
// A single file (glb, u3ma) or a directory (gltf, u3m).
[[nodiscard]] bool is_single_file(ExportFormat format);

struct ExportOptions {
  bool directx_normal = false;  // also a DirectX-convention normal map
  int repeats = 1;              // glTF: the quad shows the material this many times a side
};

// Whether `out` suits `format`: a .glb or .u3ma file is named so; a gltf or
// u3m folder is not named like the file it holds. Bad input naming --out.
[[nodiscard]] Status check_export_path(ExportFormat format, const std::filesystem::path& out);

// Checks `out` (check_export_path), then writes the export.
[[nodiscard]] Result<ExportResult> export_material(const MaterialSource& source,
                                                   ExportFormat format,
                                                   const std::filesystem::path& out,
                                                   const ExportOptions& options = {});

}  // namespace psrig::export_
