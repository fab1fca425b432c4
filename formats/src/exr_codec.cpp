#include "exr_codec.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

namespace psrig::formats::exr {

// OpenCV's EXR compression flags are OpenEXR's values.
static_assert(static_cast<int>(cv::IMWRITE_EXR_COMPRESSION_NO) ==
              static_cast<int>(Imf::NO_COMPRESSION));
static_assert(static_cast<int>(cv::IMWRITE_EXR_COMPRESSION_ZIP) ==
              static_cast<int>(Imf::ZIP_COMPRESSION));
static_assert(static_cast<int>(cv::IMWRITE_EXR_COMPRESSION_PIZ) ==
              static_cast<int>(Imf::PIZ_COMPRESSION));
static_assert(static_cast<int>(cv::IMWRITE_EXR_COMPRESSION_DWAB) ==
              static_cast<int>(Imf::DWAB_COMPRESSION));

bool can_write(const cv::Mat& image) {
  return image.depth() == CV_32F && (image.channels() == 1 || image.channels() == 3) &&
         !image.empty();
}

Status write(const std::filesystem::path& file, const cv::Mat& image, bool half, int compression,
             const ImageMetadata& metadata) {
  if (!can_write(image)) return std::unexpected(internal_error("exr::write: unsupported image"));
  cv::Mat pixels;
  if (half)
    image.convertTo(pixels, CV_16F);  // IEEE binary16, Imath::half's layout
  else
    pixels = image.isContinuous() ? image : image.clone();
  const Imf::PixelType type = half ? Imf::HALF : Imf::FLOAT;
  try {
    Imf::Header header(image.cols, image.rows);
    if (compression < 0 || compression >= Imf::NUM_COMPRESSION_METHODS)
      return std::unexpected(internal_error("exr::write: unknown compression"));
    header.compression() = static_cast<Imf::Compression>(compression);
    for (const auto& [keyword, text] : metadata.text)
      header.insert(keyword, Imf::StringAttribute(text));
    if (metadata.pixel_size_mm && *metadata.pixel_size_mm > 0) {
      Imf::addXDensity(header, static_cast<float>(25.4 / *metadata.pixel_size_mm));
      header.insert(metadata_keys::kPixelSize,
                    Imf::StringAttribute(std::to_string(*metadata.pixel_size_mm)));
    }
    Imf::FrameBuffer frame;
    const std::size_t element = pixels.elemSize();
    const std::size_t row = pixels.step[0];
    const std::size_t channel_bytes = pixels.elemSize1();
    char* base = reinterpret_cast<char*>(pixels.data);
    if (pixels.channels() == 1) {
      header.channels().insert("Y", Imf::Channel(type));
      frame.insert("Y", Imf::Slice(type, base, element, row));
    } else {
      const char* names[3] = {"B", "G", "R"};  // OpenCV's order
      for (int c = 0; c < 3; ++c) {
        header.channels().insert(names[c], Imf::Channel(type));
        frame.insert(names[c], Imf::Slice(type, base + c * channel_bytes, element, row));
      }
    }
    Imf::OutputFile out(file.c_str(), header);
    out.setFrameBuffer(frame);
    out.writePixels(image.rows);
  } catch (const std::exception& e) {
    return std::unexpected(io_error(file, std::string("cannot write EXR: ") + e.what()));
  }
  return {};
}

}  // namespace psrig::formats::exr
