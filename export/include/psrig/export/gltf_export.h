#pragma once
// glTF 2.0 out (Khronos, https://registry.khronos.org/glTF/specs/2.0/): a
// quad of the material's physical size in metres carrying its base colour
// and normal map (OpenGL convention, as glTF's), a repeating sampler with
// KHR_texture_transform, and KHR_materials_sheen for cloth. glTF has no
// displacement: the height map travels beside the model (extras.psrig.height
// says where and what its grey levels mean).

#include <filesystem>
#include <string>
#include <vector>

#include "psrig/base/error.h"
#include "psrig/export/material_source.h"

namespace psrig::export_ {

struct GltfOptions {
  // .glb: one binary file, textures inside, the height map beside it as
  // STEM_height.png. Otherwise `out` is a directory made whole or not at
  // all: STEM.gltf, STEM.bin and the textures.
  bool binary = true;
  // Also a DirectX-convention normal map beside (normal_directx.png, or
  // STEM_normal_directx.png beside a .glb), for Substance and Unreal.
  bool directx_normal = false;
  // The quad shows the material this many times along each side, at its
  // physical size (KHR_texture_transform's scale).
  int repeats = 1;
};

struct ExportResult {
  std::filesystem::path output;               // the file or directory made
  std::vector<std::filesystem::path> beside;  // files written beside a single-file export
  double width_mm = 0;                        // the material's size (pixels without a pixel size)
  double height_mm = 0;
  std::vector<std::string> warnings;
};

// What an export of `source` into `out` starts from: its size and the
// source's warnings.
[[nodiscard]] ExportResult export_result(const MaterialSource& source,
                                         const std::filesystem::path& out);

// Writes the glTF of `source` to `out`. An existing `out` is replaced only
// when it is an earlier export (a .glb file, or a directory holding
// STEM.gltf); nothing is half-written.
[[nodiscard]] Result<ExportResult> export_gltf(const MaterialSource& source,
                                               const std::filesystem::path& out,
                                               const GltfOptions& options = {});

}  // namespace psrig::export_
