#include "psrig/formats/frame_bands.h"

#include <utility>

#include "frame_bands_state.h"
#include "psrig/formats/image_io.h"

namespace psrig::formats {

FrameBands::FrameBands() : state_(std::make_unique<State>()) {}
FrameBands::FrameBands(std::unique_ptr<State> state) : state_(std::move(state)) {}
FrameBands::FrameBands(FrameBands&&) noexcept = default;
FrameBands& FrameBands::operator=(FrameBands&&) noexcept = default;
FrameBands::~FrameBands() = default;

bool FrameBands::pending(std::size_t index) const {
  return index < state_->frames.size() && state_->frames[index].reader.has_value();
}

Status FrameBands::decode(std::size_t index, int first, int rows) {
  if (!pending(index)) return {};
  State::Frame& frame = state_->frames[index];
  if (first != frame.next_row || rows < 0 || first + rows > frame.size.height)
    return std::unexpected(internal_error("FrameBands: bands out of order for " + frame.key));
  cv::Mat band(rows, frame.size.width, frame.type, frame.data + first * frame.step, frame.step);
  try {
    if (frame.reader->read(band)) {
      frame.next_row += rows;
      if (frame.next_row == frame.size.height) frame.reader.reset();
      return {};
    }
    // Damaged data: as read_image judges the frame when psrig's path gives
    // up on it (OpenCV's reader decides).
    frame.reader.reset();
    auto whole = read_image(frame.file, frame.key);
    if (!whole) return std::unexpected(whole.error());
    if (whole->size() != frame.size || whole->type() != frame.type)
      return std::unexpected(
          bad_input(frame.file, frame.key, "reads differently from one time to the next"));
    cv::Mat rest(frame.size.height - first, frame.size.width, frame.type, band.data, frame.step);
    whole->rowRange(first, frame.size.height).copyTo(rest);
    return {};
  } catch (const std::exception& e) {  // out of memory
    return std::unexpected(internal_error(frame.file.string() + ": cannot read: " + e.what()));
  }
}

}  // namespace psrig::formats
