// Writes the corpus/png/psrig-*.png seeds with psrig's own PNG writer
// (formats::write_image: ISA-L deflate at levels 1 and 9, stored at 0).
// Not built by CMake; by hand, after a normal build (W = repository root):
//   g++ -std=c++23 tests/fuzz/tools/write_psrig_png_seeds.cpp -I$W/processing/include \
//     -I$W/base/include -isystem /usr/include/opencv4 -DSPDLOG_COMPILED_LIB -DSPDLOG_FMT_EXTERNAL \
//     -DSPDLOG_SHARED_LIB -DFMT_SHARED build/lib/libpsrig_processing.a build/lib/libpsrig_base.a \
//     -lopencv_imgcodecs -lopencv_imgproc -lopencv_core -lisal -lfftw3f_threads -lfftw3f -lspdlog \
//     -lfmt -o /tmp/write_psrig_png_seeds && /tmp/write_psrig_png_seeds tests/fuzz/corpus/png
#include <cstdio>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "psrig/formats/image_io.h"
int main(int, char** argv) {
  namespace p = psrig::processing;
  const std::string out = argv[1];
  cv::RNG rng(7);
  auto m = [&](int rows, int cols, int type) { cv::Mat x(rows, cols, type); rng.fill(x, cv::RNG::UNIFORM, 0, CV_MAT_DEPTH(type) == CV_16U ? 65535 : 255); return x; };
  bool ok = true;
  ok &= bool(p::write_image(out + "/psrig-grey16-isal-level1.png", m(5, 7, CV_16UC1)));
  ok &= bool(p::write_image(out + "/psrig-rgb8-isal-level1.png", m(5, 7, CV_8UC3)));
  ok &= bool(p::write_image(out + "/psrig-rgb16-stored-level0.png", m(4, 3, CV_16UC3), std::vector<int>{cv::IMWRITE_PNG_COMPRESSION, 0}));
  ok &= bool(p::write_image(out + "/psrig-grey8-isal-level9.png", cv::Mat(6, 9, CV_8UC1, cv::Scalar(200)), std::vector<int>{cv::IMWRITE_PNG_COMPRESSION, 9}));
  return ok ? 0 : 1;
}
