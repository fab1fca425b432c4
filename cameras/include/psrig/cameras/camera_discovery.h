#pragma once
// The cameras psrig could use, for `psrig devices`: V4L2 capture nodes with
// the formats they offer, and libcamera's cameras.

#include <string>
#include <vector>

namespace psrig::cameras {

struct FoundCamera {
  std::string backend;      // "v4l2" | "libcamera"
  std::string device;       // what camera.device takes
  std::string description;  // driver, card, bus, formats psrig converts
};

// Finding nothing is an empty list; a backend that cannot look at all adds
// an entry saying why.
[[nodiscard]] std::vector<FoundCamera> find_cameras();

}  // namespace psrig::cameras
