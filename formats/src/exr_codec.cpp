#include "exr_codec.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <algorithm>
#include <atomic>
#include <bit>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "psrig/base/parallel.h"

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

struct Writer::State {
  std::filesystem::path file;
  cv::Size size;
  int channels = 1;
  bool half = false;
  int rows_written = 0;
  std::unique_ptr<Imf::OutputFile> out;
};

Writer::Writer(std::unique_ptr<State> state) : state_(std::move(state)) {}
Writer::Writer(Writer&&) noexcept = default;
Writer& Writer::operator=(Writer&&) noexcept = default;
Writer::~Writer() = default;

Result<Writer> Writer::open(const std::filesystem::path& file, cv::Size size, int channels,
                            bool half, int compression, const ImageMetadata& metadata) {
  if ((channels != 1 && channels != 3) || size.width <= 0 || size.height <= 0)
    return std::unexpected(internal_error("exr::write: unsupported image"));
  if (compression < 0 || compression >= Imf::NUM_COMPRESSION_METHODS)
    return std::unexpected(internal_error("exr::write: unknown compression"));
  auto state = std::make_unique<State>();
  state->file = file;
  state->size = size;
  state->channels = channels;
  state->half = half;
  const Imf::PixelType type = half ? Imf::HALF : Imf::FLOAT;
  try {
    Imf::Header header(size.width, size.height);
    header.compression() = static_cast<Imf::Compression>(compression);
    for (const auto& [keyword, text] : metadata.text)
      header.insert(keyword, Imf::StringAttribute(text));
    if (metadata.pixel_size_mm && *metadata.pixel_size_mm > 0) {
      Imf::addXDensity(header, static_cast<float>(25.4 / *metadata.pixel_size_mm));
      header.insert(metadata_keys::kPixelSize,
                    Imf::StringAttribute(std::to_string(*metadata.pixel_size_mm)));
    }
    if (channels == 1) {
      header.channels().insert("Y", Imf::Channel(type));
    } else {
      for (const char* name : {"B", "G", "R"})  // OpenCV's order
        header.channels().insert(name, Imf::Channel(type));
    }
    state->out = std::make_unique<Imf::OutputFile>(file.c_str(), header);
  } catch (const std::exception& e) {
    return std::unexpected(io_error(file, std::string("cannot write EXR: ") + e.what()));
  }
  return Writer(std::move(state));
}

Status Writer::write(const cv::Mat& rows) {
  State& s = *state_;
  if (rows.depth() != CV_32F || rows.channels() != s.channels || rows.cols != s.size.width ||
      s.rows_written + rows.rows > s.size.height)
    return std::unexpected(internal_error("exr::Writer: rows of the wrong size or type"));
  if (rows.rows == 0) return {};
  cv::Mat pixels;
  if (s.half)
    rows.convertTo(pixels, CV_16F);  // IEEE binary16, Imath::half's layout
  else
    pixels = rows.isContinuous() ? rows : rows.clone();
  const Imf::PixelType type = s.half ? Imf::HALF : Imf::FLOAT;
  try {
    Imf::FrameBuffer frame;
    const std::size_t element = pixels.elemSize();
    const std::size_t row = pixels.step[0];
    const std::size_t channel_bytes = pixels.elemSize1();
    // OpenEXR addresses a slice by the file's line numbers: the base is
    // where line 0 would be, lines before this band's first included.
    char* base = reinterpret_cast<char*>(pixels.data) -
                 static_cast<std::ptrdiff_t>(s.rows_written) * static_cast<std::ptrdiff_t>(row);
    if (s.channels == 1) {
      frame.insert("Y", Imf::Slice(type, base, element, row));
    } else {
      const char* names[3] = {"B", "G", "R"};  // OpenCV's order
      for (int c = 0; c < 3; ++c)
        frame.insert(names[c], Imf::Slice(type, base + c * channel_bytes, element, row));
    }
    s.out->setFrameBuffer(frame);
    s.out->writePixels(rows.rows);
  } catch (const std::exception& e) {
    return std::unexpected(io_error(s.file, std::string("cannot write EXR: ") + e.what()));
  }
  s.rows_written += rows.rows;
  return {};
}

Status Writer::finish() {
  State& s = *state_;
  if (s.rows_written != s.size.height)
    return std::unexpected(internal_error("exr::Writer: finished before the last row"));
  try {
    s.out.reset();  // the line offsets, and the file closed
  } catch (const std::exception& e) {
    return std::unexpected(io_error(s.file, std::string("cannot write EXR: ") + e.what()));
  }
  return {};
}

Status write(const std::filesystem::path& file, const cv::Mat& image, bool half, int compression,
             const ImageMetadata& metadata) {
  if (!can_write(image)) return std::unexpected(internal_error("exr::write: unsupported image"));
  auto writer = Writer::open(file, image.size(), image.channels(), half, compression, metadata);
  if (!writer) return std::unexpected(writer.error());
  if (auto ok = writer->write(image); !ok) return ok;
  return writer->finish();
}

namespace {

// An uncompressed float file's lines as stored (each channel's samples in
// turn, channels in name order, little-endian), interleaved into `image`
// here: OpenEXR's own copy goes a sample at a time, 5x slower. The lines in
// a few runs on the pool, each through its own handle on the file.
bool read_raw_floats(const std::filesystem::path& file, const Imf::InputFile& in, cv::Mat& image) {
  if constexpr (std::endian::native != std::endian::little) return false;
  if (in.header().hasTileDescription()) return false;
  const int channels = image.channels();
  const std::size_t line_bytes = static_cast<std::size_t>(image.cols) * channels * sizeof(float);
  const int runs = std::max(1, std::min(thread_count(), image.rows / 64));
  std::atomic<bool> ok = true;
  parallel_chunks(image.rows, (image.rows + runs - 1) / runs, [&](int begin, int end) {
    try {
      const Imf::InputFile run(file.c_str());
      std::vector<char> line(line_bytes);
      for (int y = begin; y < end && ok; ++y) {
        int size = static_cast<int>(line_bytes);
        run.rawPixelDataToBuffer(y, line.data(), size);
        if (static_cast<std::size_t>(size) != line_bytes) {
          ok = false;
          return;
        }
        float* out = image.ptr<float>(y);
        for (int c = 0; c < channels; ++c) {
          const char* plane =
              line.data() + static_cast<std::size_t>(c) * image.cols * sizeof(float);
          for (int x = 0; x < image.cols; ++x)
            std::memcpy(out + static_cast<std::size_t>(x) * channels + c, plane + x * sizeof(float),
                        sizeof(float));
        }
      }
    } catch (const std::exception&) {
      ok = false;
    }
  });
  return ok;
}

}  // namespace

std::optional<cv::Mat> read(const std::filesystem::path& file) {
  try {
    Imf::InputFile in(file.c_str());
    const Imf::Header& header = in.header();
    const Imath::Box2i window = header.dataWindow();
    if (window.min.x != 0 || window.min.y != 0 || window.max.x < 0 || window.max.y < 0)
      return std::nullopt;
    const int width = window.max.x + 1;
    const int height = window.max.y + 1;
    // The channels, in the Mat's order: Y, or B, G, R.
    std::vector<std::string> names;
    std::optional<Imf::PixelType> stored;
    for (auto channel = header.channels().begin(); channel != header.channels().end(); ++channel) {
      const Imf::Channel& c = channel.channel();
      if (c.xSampling != 1 || c.ySampling != 1) return std::nullopt;
      if (c.type != Imf::HALF && c.type != Imf::FLOAT) return std::nullopt;
      if (stored && *stored != c.type) return std::nullopt;
      stored = c.type;
      names.emplace_back(channel.name());
    }
    std::sort(names.begin(), names.end());  // the map's order, made explicit
    const std::vector<std::string> grey = {"Y"};
    const std::vector<std::string> colour = {"B", "G", "R"};
    if (names != grey && names != colour) return std::nullopt;
    cv::Mat image(height, width, CV_32FC(static_cast<int>(names.size())));
    if (header.compression() == Imf::NO_COMPRESSION && *stored == Imf::FLOAT && in.isComplete() &&
        read_raw_floats(file, in, image))
      return image;
    Imf::FrameBuffer frame;
    char* base = reinterpret_cast<char*>(image.data);
    for (std::size_t c = 0; c < names.size(); ++c)
      frame.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), image.elemSize(),
                                        image.step[0]));
    in.setFrameBuffer(frame);
    in.readPixels(0, height - 1);
    return image;
  } catch (const std::exception&) {  // damaged or unreadable: OpenCV's reader decides
    return std::nullopt;
  }
}

}  // namespace psrig::formats::exr
