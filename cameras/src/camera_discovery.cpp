#include "psrig/cameras/camera_discovery.h"

#include <algorithm>
#include <cerrno>
#include <fcntl.h>
#include <filesystem>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include "psrig/cameras/libcamera_camera.h"
#include "psrig/cameras/v4l2_formats.h"
#include "v4l2/v4l2_device.h"

namespace psrig::cameras {
namespace {

using v4l2::xioctl;

namespace fs = std::filesystem;

std::string text(const __u8* bytes, std::size_t size) {
  const auto* chars = reinterpret_cast<const char*>(bytes);
  return {chars, strnlen(chars, size)};
}

// A capture node's driver, card and formats; nothing for metadata nodes,
// encoders and the like.
std::optional<FoundCamera> describe_v4l2_node(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDWR | O_NONBLOCK);
  if (fd < 0) return FoundCamera{"v4l2", path, std::string("cannot open: ") + std::strerror(errno)};
  v4l2_capability caps{};
  std::optional<FoundCamera> found;
  if (xioctl(fd, VIDIOC_QUERYCAP, &caps) == 0) {
    const __u32 device_caps =
        caps.capabilities & V4L2_CAP_DEVICE_CAPS ? caps.device_caps : caps.capabilities;
    if (device_caps & V4L2_CAP_VIDEO_CAPTURE) {
      std::string formats, other;
      v4l2_fmtdesc format{};
      format.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      for (format.index = 0; xioctl(fd, VIDIOC_ENUM_FMT, &format) == 0; ++format.index) {
        std::string& list = find_v4l2_format(format.pixelformat) ? formats : other;
        list += (list.empty() ? "" : " ") + fourcc_to_string(format.pixelformat);
      }
      std::string description = text(caps.driver, sizeof caps.driver) + " \"" +
                                text(caps.card, sizeof caps.card) + "\" (" +
                                text(caps.bus_info, sizeof caps.bus_info) +
                                "), formats psrig takes: " + (formats.empty() ? "none" : formats);
      if (!other.empty()) description += "; others: " + other;
      found = FoundCamera{"v4l2", path, description};
    }
  }
  ::close(fd);
  return found;
}

}  // namespace

std::vector<FoundCamera> find_cameras() {
  std::vector<FoundCamera> found;
  std::vector<std::string> nodes;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator("/dev", ec))
    if (entry.path().filename().string().starts_with("video"))
      nodes.push_back(entry.path().string());
  std::sort(nodes.begin(), nodes.end(), [](const std::string& a, const std::string& b) {
    return a.size() != b.size() ? a.size() < b.size() : a < b;  // video2 before video10
  });
  for (const auto& node : nodes)
    if (auto camera = describe_v4l2_node(node)) found.push_back(std::move(*camera));

  if (auto cameras = list_libcamera_cameras(); !cameras)
    found.push_back({"libcamera", "", "cannot look: " + cameras.error().describe()});
  else
    for (const auto& camera : *cameras)
      found.push_back({"libcamera", camera.substr(0, camera.find(" (")), camera});
  return found;
}

}  // namespace psrig::cameras
