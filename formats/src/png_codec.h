#pragma once
// A fast path for the PNGs psrig moves most: 12 MP 16-bit frames and maps.
// libpng inflates with zlib and filters adaptively; this path (de)compresses
// with ISA-L a batch of rows at a time, 2-3x faster, with OpenCV's libpng
// path kept for everything outside the subset handled here: 8- or 16-bit
// grey or RGB, not interlaced, no transparency.

#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/formats/image_metadata.h"

namespace psrig::formats::png {

// The image, in OpenCV's layout (BGR, native-endian 16-bit), or nothing when
// the file is not a PNG this path handles, including one it finds damaged:
// then cv::imread decides, so every PNG is judged as OpenCV would.
[[nodiscard]] std::optional<cv::Mat> read(const std::filesystem::path& file);

// read() a band of rows at a time, top to bottom: the same pixels, with no
// buffer the size of the image and the compressed bytes already read given
// back as it goes (the file is mapped while the reader lives).
class Reader {
 public:
  // Nothing for a file read() gives nothing for from its chunks alone (not
  // a PNG, damaged chunks, a kind this path leaves to OpenCV); damage in
  // the compressed data shows only as it is read.
  [[nodiscard]] static std::optional<Reader> open(const std::filesystem::path& file);
  [[nodiscard]] cv::Size size() const;
  [[nodiscard]] int type() const;  // as read() gives it: BGR, native-endian 16-bit
  // The next rows.rows rows into `rows` (size().width wide, of type());
  // false when the data is damaged or ends early, and, with the last row,
  // when the stream does not end there with its checksum right.
  [[nodiscard]] bool read(cv::Mat& rows);

  Reader(Reader&&) noexcept;
  Reader& operator=(Reader&&) noexcept;
  ~Reader();

 private:
  struct State;
  explicit Reader(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

// Where a chunk of the PNG `file` declares more bytes than the file holds
// after it, which chunk and how much; nothing when every chunk fits (or the
// file is no PNG). libpng would first allocate the declared length, up to
// 2 GiB, before finding the file short.
[[nodiscard]] std::optional<std::string> chunk_past_end(const std::filesystem::path& file);

// Whether write() takes this image: CV_8U or CV_16U, one or three channels.
[[nodiscard]] bool can_write(const cv::Mat& image);

// Writes with zlib-scale compression `level` (0 stores, 1 fastest … 9),
// with `metadata`'s chunks (pHYs, sRGB+gAMA+cHRM or gAMA 1.0, tEXt/iTXt)
// before the image data.
[[nodiscard]] Status write(const std::filesystem::path& file, const cv::Mat& image, int level,
                           const ImageMetadata& metadata = {});

// write() a band of rows at a time, top to bottom: the same bytes, with no
// copy of the whole image (filtered or compressed) held at any time.
class Writer {
 public:
  // Creates `file` and writes everything before the pixels: a `size` image of
  // `type` (as can_write takes), compression `level`, `metadata`.
  [[nodiscard]] static Result<Writer> open(const std::filesystem::path& file, cv::Size size,
                                           int type, int level, const ImageMetadata& metadata);
  // The next rows: `size.width` wide, of `type`.
  [[nodiscard]] Status write(const cv::Mat& rows);
  // After the last row: the rest of the file, closed.
  [[nodiscard]] Status finish();

  Writer(Writer&&) noexcept;
  Writer& operator=(Writer&&) noexcept;
  ~Writer();

 private:
  struct State;
  explicit Writer(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

}  // namespace psrig::formats::png
