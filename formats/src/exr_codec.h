#pragma once
// EXR files with header attributes, through OpenEXR itself: OpenCV's
// writer has no way to add attributes. Pixels as cv::imwrite writes them
// (grey as Y; OpenCV's BGR as R, G, B), uncompressed. And a fast path for
// reading the EXRs psrig writes (ground truth, maps) straight into their Mat.

#include <filesystem>
#include <memory>
#include <optional>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/formats/image_metadata.h"

namespace psrig::formats::exr {

// Whether write() takes this image: CV_32F, one or three channels.
[[nodiscard]] bool can_write(const cv::Mat& image);

// Writes 32-bit float, or half when `half`, compressed by `compression`
// (cv::ImwriteEXRCompressionFlags, whose values are OpenEXR's own), with
// `metadata` as attributes: the text as string attributes under their
// keywords, the pixel size as the standard xDensity (pixels per inch) and
// psrig:pixel_size_mm.
[[nodiscard]] Status write(const std::filesystem::path& file, const cv::Mat& image, bool half,
                           int compression, const ImageMetadata& metadata);

// write() a band of rows at a time, top to bottom: the same bytes, with no
// copy of the whole image (in half floats) held at any time. OpenEXR
// compresses each block of lines as soon as it is whole.
class Writer {
 public:
  // Creates `file` for a `size` image of `channels` (1 or 3) float channels,
  // stored as write() stores them.
  [[nodiscard]] static Result<Writer> open(const std::filesystem::path& file, cv::Size size,
                                           int channels, bool half, int compression,
                                           const ImageMetadata& metadata);
  // The next rows: CV_32F, `channels`, `size.width` wide.
  [[nodiscard]] Status write(const cv::Mat& rows);
  // After the last row: the line offsets written and the file closed.
  [[nodiscard]] Status finish();

  Writer(Writer&&) noexcept;
  Writer& operator=(Writer&&) noexcept;
  ~Writer();

 private:
  struct State;
  explicit Writer(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

// The image as cv::imread(IMREAD_UNCHANGED) gives it (CV_32FC1 from a Y
// channel, CV_32FC3 in BGR order from R, G, B; half samples widened to
// float), read by OpenEXR straight into the Mat: 4-6x faster than OpenCV's
// reader, which converts a scanline at a time. Only for files whose
// channels are Y alone or exactly R, G, B, all half or all float, none
// subsampled, with the data window at the origin; nothing for any other
// file and for one OpenEXR cannot read (then cv::imread decides, so every
// EXR is judged as OpenCV would).
[[nodiscard]] std::optional<cv::Mat> read(const std::filesystem::path& file);

}  // namespace psrig::formats::exr
