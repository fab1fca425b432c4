#include "psrig/formats/row_writer.h"

#include <optional>
#include <utility>

#include "exr_codec.h"
#include "image_params.h"
#include "png_codec.h"

namespace psrig::formats {

struct RowWriter::Encoder {
  std::optional<png::Writer> png;
  std::optional<exr::Writer> exr;
};

RowWriter::RowWriter(std::unique_ptr<Encoder> encoder) : encoder_(std::move(encoder)) {}
RowWriter::RowWriter(RowWriter&&) noexcept = default;
RowWriter& RowWriter::operator=(RowWriter&&) noexcept = default;
RowWriter::~RowWriter() = default;

Result<RowWriter> RowWriter::open(const std::filesystem::path& file, cv::Size size, int type,
                                  const std::vector<int>& params, const ImageMetadata& metadata) {
  auto encoder = std::make_unique<Encoder>();
  const int depth = CV_MAT_DEPTH(type);
  const int channels = CV_MAT_CN(type);
  if (is_png(file) && (depth == CV_8U || depth == CV_16U) && (channels == 1 || channels == 3)) {
    auto writer = png::Writer::open(file, size, type, png_level(params), metadata);
    if (!writer) return std::unexpected(writer.error());
    encoder->png.emplace(std::move(*writer));
  } else if (is_exr(file) && depth == CV_32F && (channels == 1 || channels == 3)) {
    auto writer = exr::Writer::open(file, size, channels, exr_half(params), exr_compression(params),
                                    metadata);
    if (!writer) return std::unexpected(writer.error());
    encoder->exr.emplace(std::move(*writer));
  } else {
    return std::unexpected(
        internal_error("RowWriter: " + file.filename().string() + " cannot be written by rows"));
  }
  return RowWriter(std::move(encoder));
}

Status RowWriter::write(const cv::Mat& rows) {
  try {
    return encoder_->png ? encoder_->png->write(rows) : encoder_->exr->write(rows);
  } catch (const std::exception& e) {  // out of memory
    return std::unexpected(internal_error(std::string("RowWriter: ") + e.what()));
  }
}

Status RowWriter::finish() {
  return encoder_->png ? encoder_->png->finish() : encoder_->exr->finish();
}

}  // namespace psrig::formats
