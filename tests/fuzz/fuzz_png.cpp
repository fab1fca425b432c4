// PNG files, as processing's read_image() takes them: the input becomes a
// .png file read through psrig's fast path (ISA-L inflate, 8/16-bit grey or
// RGB, not interlaced, no transparency) with cv::imread as the fallback for
// everything else. Inputs that do not start with the PNG signature are
// skipped: cv::imread picks its decoder by content, and the other formats'
// decoders (TIFF, EXR, WebP, ...) are Debian's libraries, not psrig.
//
// Besides crashes and sanitizer reports, one oracle: read_image promises
// that "every PNG is judged as OpenCV would", so whatever it decodes must be
// what cv::imdecode makes of the same bytes, pixel for pixel.

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "fuzz_support.h"
#include "psrig/formats/image_io.h"

namespace {
constexpr std::uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  psrig::fuzz::quiet_logs();
  cv::setNumThreads(1);  // one input at a time; OpenCV's pool only adds noise
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < sizeof kSignature || !std::equal(kSignature, kSignature + 8, data)) return 0;
  static const auto file = psrig::fuzz::scratch_directory() / "frame.png";
  psrig::fuzz::write_file(file, data, size);
  auto image = psrig::formats::read_image(file, "lights[0].image");
  if (!image) {
    (void)image.error().describe();
    return 0;
  }
  const std::vector<std::uint8_t> bytes(data, data + size);
  cv::Mat reference;
  try {
    reference = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception&) {
  }
  if (reference.empty()) return 0;  // psrig's path took a file libpng refuses: allowed
  if (reference.size() != image->size() || reference.type() != image->type() ||
      cv::norm(reference, *image, cv::NORM_INF) != 0) {
    std::fprintf(stderr, "fuzz_png: read_image gives %dx%d type %d, cv::imdecode %dx%d type %d%s\n",
                 image->cols, image->rows, image->type(), reference.cols, reference.rows,
                 reference.type(),
                 reference.size() == image->size() && reference.type() == image->type()
                     ? ", pixels differ"
                     : "");
    std::abort();
  }
  return 0;
}
