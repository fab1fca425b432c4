#include "psrig/export/export_format.h"

#include "psrig/export/u3m_export.h"

namespace psrig::export_ {

std::optional<ExportFormat> parse_export_format(std::string_view name) {
  if (name == "glb") return ExportFormat::glb;
  if (name == "gltf") return ExportFormat::gltf;
  if (name == "u3m") return ExportFormat::u3m;
  if (name == "u3ma") return ExportFormat::u3ma;
  return std::nullopt;
}

std::string_view to_string(ExportFormat format) {
  switch (format) {
    case ExportFormat::glb:
      return "glb";
    case ExportFormat::gltf:
      return "gltf";
    case ExportFormat::u3m:
      return "u3m";
    case ExportFormat::u3ma:
      return "u3ma";
  }
  return "unknown";
}

bool is_single_file(ExportFormat format) {
  return format == ExportFormat::glb || format == ExportFormat::u3ma;
}

Status check_export_path(ExportFormat format, const std::filesystem::path& out) {
  // A single file is named for its format; a folder is not named like the
  // file it holds (swatch.gltf/ holding swatch.gltf would mislead).
  const std::string extension = "." + std::string(to_string(format));
  if (is_single_file(format) && out.extension() != extension)
    return std::unexpected(
        bad_input(out, "--out", "name the " + extension + " file, e.g. swatch" + extension));
  if (!is_single_file(format) && out.extension() == extension)
    return std::unexpected(bad_input(out, "--out",
                                     "names a folder for --format " +
                                         std::string(to_string(format)) + " (it holds STEM" +
                                         extension + " and the textures); drop the " + extension));
  return {};
}

Result<ExportResult> export_material(const MaterialSource& source, ExportFormat format,
                                     const std::filesystem::path& out,
                                     const ExportOptions& options) {
  if (auto ok = check_export_path(format, out); !ok) return std::unexpected(ok.error());
  switch (format) {
    case ExportFormat::glb:
    case ExportFormat::gltf:
      return export_gltf(source, out,
                         {format == ExportFormat::glb, options.directx_normal, options.repeats});
    case ExportFormat::u3m:
    case ExportFormat::u3ma:
      return export_u3m(source, out, {format == ExportFormat::u3ma, options.directx_normal});
  }
  return std::unexpected(internal_error("unknown export format"));
}

}  // namespace psrig::export_
