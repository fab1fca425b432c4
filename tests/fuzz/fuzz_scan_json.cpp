// scan.json, as processing's reader takes it: the input becomes scan.json in
// a scratch scan directory that holds a few tiny frames (led0..7.png grey
// 16-bit, rgb0..2.png colour 8-bit, dark.png, mask.png, flat0..2.png,
// odd.png of another size, gt_normal.exr, gt_height.exr), and goes through
// read_scan_description(); when that accepts it, read_scan() opens and
// cross-checks the frames it names. Every answer is fine except a crash, a
// sanitizer report, or an accepted description that breaks the rules the
// reader promises (3 lights or more, unit directions facing the camera).

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <opencv2/core.hpp>

#include "fuzz_support.h"
#include "psrig/formats/image_io.h"
#include "psrig/formats/scan_reader.h"

namespace {

namespace fs = std::filesystem;
using psrig::formats::write_image;

fs::path directory() {
  static const fs::path dir = [] {
    const fs::path d = psrig::fuzz::scratch_directory() / "scan";
    fs::create_directories(d);
    const auto put = [&](const std::string& name, const cv::Mat& image) {
      if (!write_image(d / name, image)) {
        std::fprintf(stderr, "fuzz_scan_json: cannot write %s\n", name.c_str());
        std::abort();
      }
    };
    cv::RNG rng(1);
    const auto noise = [&](int rows, int cols, int type) {
      cv::Mat m(rows, cols, type);
      rng.fill(m, cv::RNG::UNIFORM, 0, CV_MAT_DEPTH(type) == CV_16U ? 65535 : 255);
      return m;
    };
    for (int i = 0; i < 8; ++i) put("led" + std::to_string(i) + ".png", noise(6, 8, CV_16UC1));
    for (int i = 0; i < 3; ++i) put("rgb" + std::to_string(i) + ".png", noise(6, 8, CV_8UC3));
    for (int i = 0; i < 3; ++i) put("flat" + std::to_string(i) + ".png", noise(6, 8, CV_16UC1));
    put("dark.png", cv::Mat(6, 8, CV_16UC1, cv::Scalar(64)));
    put("mask.png", cv::Mat(6, 8, CV_8UC1, cv::Scalar(255)));
    put("odd.png", noise(5, 7, CV_16UC1));
    put("gt_normal.exr", cv::Mat(6, 8, CV_32FC3, cv::Scalar(0, 0, 1)));
    put("gt_height.exr", cv::Mat(6, 8, CV_32FC1, cv::Scalar(0)));
    return d;
  }();
  return dir;
}

void check(bool ok, const char* what) {
  if (ok) return;
  std::fprintf(stderr, "fuzz_scan_json: accepted a scan.json that %s\n", what);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  psrig::fuzz::quiet_logs();
  (void)directory();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const fs::path dir = directory();
  psrig::fuzz::write_file(dir / "scan.json", data, size);
  auto description = psrig::formats::read_scan_description(dir);
  if (!description) {
    (void)description.error().describe();
    return 0;
  }
  check(description->lights.size() >= 3, "has fewer than 3 lights");
  for (const auto& light : description->lights) {
    const auto& d = light.direction;
    const double norm = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    check(std::abs(norm - 1.0) < 1e-6, "has a light direction that is not a unit vector");
    check(d[2] > 0, "has a light that does not face the swatch (z <= 0)");
  }
  auto scan = psrig::formats::read_scan(dir);
  if (scan) {
    check(scan->frames.size() == description->lights.size(), "gives a frame count unlike its lights");
  } else {
    (void)scan.error().describe();
  }
  return 0;
}
