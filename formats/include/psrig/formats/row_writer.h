#pragma once
// An image file written a band of rows at a time, top to bottom, so that a
// map is encoded as it is made and no copy of the whole image (encoded, or
// in half floats) is ever held: the pipeline streams its maps through it.
// The bytes are write_image's for the whole image with the same params and
// metadata.

#include <filesystem>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/formats/image_metadata.h"

namespace psrig::formats {

class RowWriter {
 public:
  // Creates `file` for a `size` image of `type`: a PNG of 8- or 16-bit grey
  // or colour (params: cv::IMWRITE_PNG_COMPRESSION), or an EXR of one or
  // three float channels (params: cv::IMWRITE_EXR_TYPE,
  // cv::IMWRITE_EXR_COMPRESSION) as write_image writes it with metadata.
  // Any other file or type is refused (write_image takes those whole).
  [[nodiscard]] static Result<RowWriter> open(const std::filesystem::path& file, cv::Size size,
                                              int type, const std::vector<int>& params,
                                              const ImageMetadata& metadata);
  // The next rows: `size.width` wide, of `type`.
  [[nodiscard]] Status write(const cv::Mat& rows);
  // After the last row: the file complete and closed.
  [[nodiscard]] Status finish();

  RowWriter(RowWriter&&) noexcept;
  RowWriter& operator=(RowWriter&&) noexcept;
  ~RowWriter();

 private:
  struct Encoder;
  explicit RowWriter(std::unique_ptr<Encoder> encoder);
  std::unique_ptr<Encoder> encoder_;
};

}  // namespace psrig::formats
