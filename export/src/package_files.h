#pragma once
// The textures' names inside an export package (a glTF folder, a U3M):
// the package's own, spelled once here. They read like the maps
// directory's (formats/scan_layout.h) but are a different format's, and
// do not change when the maps' do.

namespace psrig::export_::package_files {

inline constexpr const char* kAlbedo = "albedo.png";
inline constexpr const char* kNormal = "normal.png";
inline constexpr const char* kNormalDirectx = "normal_directx.png";
inline constexpr const char* kHeight = "height.png";
inline constexpr const char* kOcclusion = "occlusion.png";  // glTF
inline constexpr const char* kPreview = "preview.png";      // U3M

}  // namespace psrig::export_::package_files
