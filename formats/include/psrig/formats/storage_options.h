#pragma once
// How the maps (and a scan's frames) are stored on disk, chosen by
// [storage] in rig.toml or psrig process's --exr-compression, --png-level
// and --map-precision. Frames are always lossless: they are the record a
// scan can be processed again from.

#include <optional>
#include <string_view>
#include <vector>

#include <opencv2/imgcodecs.hpp>

namespace psrig::formats {

// OpenEXR's lossless codecs: ZIP (deflate over 16 rows, with OpenEXR's
// byte split and delta predictor), PIZ (wavelet + Huffman), or none; auto
// compresses only where it pays. Measured on BM_Process/12MP's maps: PIZ
// takes the half-float albedo.exr to 47 % (ZIP 53 %), but the 32-bit float
// maps (p, q, height) hold sensor noise down to their last bits and shrink
// by 2-6 % for about a second each, so auto leaves them uncompressed.
enum class ExrCompression { none, zip, piz, automatic };

// The precision of the float maps p.exr, q.exr and height.exr. Half floats
// (11 significant bits) round a gradient to 1 part in 2048 of its value,
// at most 1/2048 rad (0.028°) of surface angle, and a height to 1 part in
// 2048 of its value: 16 times below the 0.46° mean error the solve leaves
// at BM_Process's noise (0.002 of full scale), at 38 % of the bytes once
// compressed. `full` keeps 32-bit
// floats for work that wants the solver's exact output; the frames can
// always give it again (psrig process).
enum class MapPrecision { half, full };

struct StorageOptions {
  ExrCompression exr_compression = ExrCompression::automatic;
  // zlib-scale deflate level for PNG: 0 stores, 1 fastest … 9 smallest
  // (ISA-L's levels 1-3 underneath).
  int png_level = 1;
  MapPrecision map_precision = MapPrecision::half;
};

[[nodiscard]] inline const char* to_string(MapPrecision p) {
  return p == MapPrecision::half ? "half" : "float";
}

[[nodiscard]] inline std::optional<MapPrecision> parse_map_precision(std::string_view text) {
  if (text == "half") return MapPrecision::half;
  if (text == "float") return MapPrecision::full;
  return std::nullopt;
}

[[nodiscard]] inline const char* to_string(ExrCompression c) {
  switch (c) {
    case ExrCompression::none:
      return "none";
    case ExrCompression::zip:
      return "zip";
    case ExrCompression::piz:
      return "piz";
    case ExrCompression::automatic:
      return "auto";
  }
  return "none";
}

[[nodiscard]] inline std::optional<ExrCompression> parse_exr_compression(std::string_view text) {
  if (text == "none") return ExrCompression::none;
  if (text == "zip") return ExrCompression::zip;
  if (text == "piz") return ExrCompression::piz;
  if (text == "auto") return ExrCompression::automatic;
  return std::nullopt;
}

// write_image's params for an EXR with this compression (OpenCV's flag
// values are OpenEXR's), optionally as half floats.
[[nodiscard]] inline std::vector<int> exr_params(ExrCompression c, bool half = false) {
  if (c == ExrCompression::automatic) c = half ? ExrCompression::piz : ExrCompression::none;
  const int flag = c == ExrCompression::zip   ? cv::IMWRITE_EXR_COMPRESSION_ZIP
                   : c == ExrCompression::piz ? cv::IMWRITE_EXR_COMPRESSION_PIZ
                                              : cv::IMWRITE_EXR_COMPRESSION_NO;
  return {cv::IMWRITE_EXR_COMPRESSION, flag, cv::IMWRITE_EXR_TYPE,
          half ? cv::IMWRITE_EXR_TYPE_HALF : cv::IMWRITE_EXR_TYPE_FLOAT};
}

[[nodiscard]] inline std::vector<int> png_params(int level) {
  return {cv::IMWRITE_PNG_COMPRESSION, level};
}

}  // namespace psrig::formats
