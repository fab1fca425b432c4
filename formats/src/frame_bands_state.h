#pragma once
// What FrameBands holds (frame_bands.h): per frame, where its pixels are
// and the reader decoding them, or nothing once it is whole.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "png_codec.h"
#include "psrig/formats/frame_bands.h"

namespace psrig::formats {

struct FrameBands::State {
  struct Frame {
    std::filesystem::path file;
    std::string key;
    // The frame's pixels, the scan's own Mat's (not a header sharing them:
    // the pipeline gives rows back only where the scan alone holds them).
    uchar* data = nullptr;
    std::size_t step = 0;
    cv::Size size;
    int type = 0;
    std::optional<png::Reader> reader;  // none: the frame is whole
    int next_row = 0;
  };
  std::vector<Frame> frames;
};

}  // namespace psrig::formats
