// psrig export MAPS_DIR: the maps as a material for 3D tools (glTF 2.0,
// U3M 1.1) at their physical size.

#include <cstdio>
#include <iostream>
#include <memory>

#include "command.h"
#include "psrig/export/export_format.h"
#include "psrig/export/material_source.h"

namespace psrig::cli {
namespace {

struct ExportArgs {
  std::string maps;
  std::string format;
  std::string out;
  std::string normal_convention = "opengl";
  int repeats = 1;
  bool whole_scan = false;
  bool quiet = false;
};

}  // namespace

Command add_export_command(CLI::App& parent) {
  auto args = std::make_shared<ExportArgs>();
  CLI::App* app = parent.add_subcommand(
      "export", "Export a maps (or tile) directory as glTF 2.0 or U3M 1.1 at its physical size");
  app->add_option("maps", args->maps, "Maps directory (psrig process) or tile directory")
      ->required();
  app->add_option("--format", args->format,
                  "glb (one binary glTF file), gltf (a folder: .gltf, .bin, textures), u3m (a "
                  "folder: .u3m and textures) or u3ma (the U3M archive)")
      ->check(CLI::IsMember({"glb", "gltf", "u3m", "u3ma"}))
      ->required();
  app->add_option("--out", args->out,
                  "The .glb or .u3ma file, or the folder for gltf and u3m (appears whole or not "
                  "at all; an earlier export there is replaced)")
      ->required();
  app->add_option("--normal-convention", args->normal_convention,
                  "opengl, or directx to ship a DirectX-convention normal map too "
                  "(normal_directx.png; glTF and U3M themselves use OpenGL's)")
      ->check(CLI::IsMember({"opengl", "directx"}))
      ->capture_default_str();
  app->add_option("--repeat", args->repeats,
                  "glTF: the quad shows the material N times a side (KHR_texture_transform)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app->add_flag("--whole-scan", args->whole_scan,
                "Export the whole scan rather than its seamless tile (MAPS_DIR/tile, made by "
                "psrig tile or here on first use)");
  app->add_flag("-q,--quiet", args->quiet, "Print nothing on success but warnings");

  return {app, [args] {
            const auto format = *export_::parse_export_format(args->format);
            // A wrong --out is told before the maps are read.
            if (auto ok = export_::check_export_path(format, args->out); !ok)
              return report_error("export", ok.error());
            auto source = export_::material_for_export(args->maps, args->whole_scan);
            if (!source) return report_error("export", source.error());
            for (const auto& warning : source->warnings)
              std::cerr << "psrig export: warning: " << warning << '\n';
            export_::ExportOptions options;
            options.directx_normal = args->normal_convention == "directx";
            options.repeats = args->repeats;
            auto result = export_::export_material(*source, format, args->out, options);
            if (!result) return report_error("export", result.error());
            if (!args->quiet) {
              std::printf("%s: %s\n", std::string(export_::to_string(format)).c_str(),
                          result->output.string().c_str());
              for (const auto& file : result->beside)
                std::printf("beside it: %s\n", file.string().c_str());
              std::printf("size: %.3f x %.3f %s (%d x %d px)%s\n", result->width_mm,
                          result->height_mm, source->pixel_size_mm ? "mm" : "px", source->width_px,
                          source->height_px, source->tile ? ", seamless tile" : "");
            }
            return 0;
          }};
}

}  // namespace psrig::cli
