#include "psrig/cameras/v4l2_camera.h"

#include <algorithm>
#include <cstring>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <span>
#include <sys/mman.h>
#include <sys/stat.h>
#include <thread>
#include <unistd.h>
#include <vector>

#include <spdlog/fmt/fmt.h>

#include "psrig/base/log.h"
#include "psrig/cameras/v4l2_formats.h"
#include "v4l2_controls.h"
#include "v4l2_device.h"

namespace psrig::cameras {
namespace {

using v4l2::errno_text;
using v4l2::ioctl_error;
using v4l2::xioctl;

constexpr std::uint32_t kCapture = V4L2_BUF_TYPE_VIDEO_CAPTURE;
// Enough to keep the driver filling one while we convert another.
constexpr unsigned kBufferCount = 4;
// With end-of-frame timestamps the readout time is unknown; it is at most a
// frame interval. Drivers that do not say their interval get this bound.
constexpr std::chrono::milliseconds kUnknownReadoutBound{100};
// How long to wait before asking again when poll() said ready but no frame was.
constexpr std::chrono::milliseconds kRetryPause{1};

struct Offered {
  std::uint32_t fourcc;
  std::string description;
};

std::string describe_offered(const std::vector<Offered>& offered) {
  std::string s;
  for (const auto& o : offered) {
    if (!s.empty()) s += ", ";
    s += fourcc_to_string(o.fourcc) + " (" + o.description + ")";
  }
  return s.empty() ? "nothing" : s;
}

std::string readable_formats() {
  std::string s;
  for (const auto& f : v4l2_pixel_formats()) {
    if (!s.empty()) s += " ";
    s += fourcc_to_string(f.fourcc);
  }
  return s;
}

class V4l2Camera final : public Camera {
 public:
  explicit V4l2Camera(std::string device) : device_(std::move(device)) {}
  ~V4l2Camera() override {
    (void)stop();
    if (fd_ >= 0) ::close(fd_);
  }
  V4l2Camera(const V4l2Camera&) = delete;
  V4l2Camera& operator=(const V4l2Camera&) = delete;

  Status open();
  Status configure(const config::CameraConfig& settings) override;
  Status start() override;
  Result<Frame> grab(std::chrono::milliseconds timeout) override;
  Status stop() override;
  std::string describe() const override;

 private:
  struct Buffer {
    void* data = MAP_FAILED;
    std::size_t length = 0;
  };

  Error config_error(const std::string& key, const std::string& message) const {
    return bad_input(device_, key, message);
  }
  std::string who() const { return device_ + " (" + driver_ + ", '" + card_ + "')"; }
  std::vector<Offered> offered_formats() const;
  std::vector<cv::Size> offered_sizes(std::uint32_t fourcc) const;
  Result<V4l2PixelFormat> choose_format(const std::string& wanted,
                                        const std::vector<Offered>& offered) const;
  void release_buffers();
  Error timeout_error(std::chrono::milliseconds timeout, bool lost_frames) const;

  std::string device_;
  int fd_ = -1;
  std::string driver_, card_, bus_;
  bool configured_ = false;
  V4l2PixelFormat format_;
  int width_ = 0, height_ = 0;
  std::size_t bytes_per_line_ = 0;
  std::chrono::nanoseconds frame_interval_{0};  // 0: the driver does not say
  int exposure_us_ = 0;
  double gain_ = 1.0;
  std::vector<Buffer> buffers_;
  bool streaming_ = false;
  bool vanished_ = false;
  std::uint32_t last_sequence_ = 0;
  std::uint64_t sequence_epoch_ = 0;  // counts 32-bit wraps of the driver's sequence
  bool have_sequence_ = false;
};

Status V4l2Camera::open() {
  // The node type by path, before opening, as V4L2's own capture example
  // does: user-space device emulators (umockdev) fake it for stat() only.
  struct stat st {};
  if (::stat(device_.c_str(), &st) == 0 && !S_ISCHR(st.st_mode))
    return std::unexpected(
        config_error("camera.device",
                     "is not a device node: set camera.device to a /dev/videoN (see "
                     "`v4l2-ctl --list-devices`)"));
  // Non-blocking, so that DQBUF never waits: poll() does, with our timeout.
  fd_ = ::open(device_.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) {
    const int e = errno;
    if (e == ENOENT || e == ENXIO || e == ENODEV)
      return std::unexpected(
          config_error("camera.device",
                       "no such device: list the cameras with `psrig devices` or "
                       "`v4l2-ctl --list-devices` and set camera.device to one of them"));
    if (e == EACCES || e == EPERM)
      return std::unexpected(
          io_error(device_,
                   "permission denied: add the user to the `video` group (or install "
                   "config/udev rules) and log in again"));
    if (e == EBUSY) return std::unexpected(v4l2::busy_error(device_, "opening"));
    return std::unexpected(io_error(device_, "cannot open: " + errno_text(e)));
  }
  v4l2_capability cap{};
  if (xioctl(fd_, VIDIOC_QUERYCAP, &cap) < 0) {
    const int e = errno;
    if (e == ENODEV) return std::unexpected(v4l2::vanished_error(device_, "opening"));
    return std::unexpected(
        config_error("camera.device", "is not a V4L2 device (VIDIOC_QUERYCAP: " + errno_text(e) +
                                          "): set camera.device to a /dev/videoN (see `v4l2-ctl "
                                          "--list-devices`)"));
  }
  driver_ = reinterpret_cast<const char*>(cap.driver);
  card_ = reinterpret_cast<const char*>(cap.card);
  bus_ = reinterpret_cast<const char*>(cap.bus_info);
  const std::uint32_t caps =
      (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  if (!(caps & V4L2_CAP_VIDEO_CAPTURE)) {
    std::string why = "is not a video capture device";
    if (caps & V4L2_CAP_VIDEO_CAPTURE_MPLANE)
      why =
          "is a multi-planar capture device, which the v4l2 backend does not read: use "
          "camera.backend = \"libcamera\"";
    else if (caps & V4L2_CAP_META_CAPTURE)
      why =
          "is a metadata node: the camera's pictures come from its other /dev/videoN (see "
          "`v4l2-ctl --list-devices`)";
    return std::unexpected(config_error("camera.device", who() + " " + why));
  }
  if (!(caps & V4L2_CAP_STREAMING))
    return std::unexpected(config_error(
        "camera.device", who() + " cannot stream (read()-only devices are not supported)"));
  return {};
}

std::vector<Offered> V4l2Camera::offered_formats() const {
  std::vector<Offered> offered;
  for (std::uint32_t i = 0;; ++i) {
    v4l2_fmtdesc d{};
    d.index = i;
    d.type = kCapture;
    if (xioctl(fd_, VIDIOC_ENUM_FMT, &d) < 0) break;
    offered.push_back({d.pixelformat, reinterpret_cast<const char*>(d.description)});
  }
  return offered;
}

// Discrete sizes, or the largest of a range; empty when the driver does not say.
std::vector<cv::Size> V4l2Camera::offered_sizes(std::uint32_t fourcc) const {
  std::vector<cv::Size> sizes;
  for (std::uint32_t i = 0;; ++i) {
    v4l2_frmsizeenum s{};
    s.index = i;
    s.pixel_format = fourcc;
    if (xioctl(fd_, VIDIOC_ENUM_FRAMESIZES, &s) < 0) break;
    if (s.type == V4L2_FRMSIZE_TYPE_DISCRETE) {
      sizes.emplace_back(static_cast<int>(s.discrete.width), static_cast<int>(s.discrete.height));
    } else {
      sizes.emplace_back(static_cast<int>(s.stepwise.max_width),
                         static_cast<int>(s.stepwise.max_height));
      break;
    }
  }
  return sizes;
}

Result<V4l2PixelFormat> V4l2Camera::choose_format(const std::string& wanted,
                                                  const std::vector<Offered>& offered) const {
  const auto offers = [&](std::uint32_t fourcc) {
    return std::any_of(offered.begin(), offered.end(),
                       [&](const Offered& o) { return o.fourcc == fourcc; });
  };
  if (wanted.empty() || wanted == "auto") {
    // The formats are listed best for photometry first.
    for (const auto& f : v4l2_pixel_formats())
      if (offers(f.fourcc)) return f;
    return std::unexpected(config_error(
        "camera.format", who() + " offers no format psrig reads: it offers " +
                             describe_offered(offered) + "; psrig reads " + readable_formats()));
  }
  const auto f = find_v4l2_format(wanted);
  if (!f)
    return std::unexpected(config_error(
        "camera.format", "'" + wanted + "' is not a format psrig reads (it reads " +
                             readable_formats() + "); " + who() + " offers " +
                             describe_offered(offered) + "; or set camera.format = \"auto\""));
  if (!offers(f->fourcc))
    return std::unexpected(
        config_error("camera.format", who() + " does not offer " + fourcc_to_string(f->fourcc) +
                                          "; it offers " + describe_offered(offered) +
                                          ": set camera.format to one of those or to \"auto\""));
  return *f;
}

Status V4l2Camera::configure(const config::CameraConfig& settings) {
  if (streaming_) return std::unexpected(internal_error(device_ + ": configure() while streaming"));
  configured_ = false;
  const auto offered = offered_formats();
  auto format = choose_format(settings.format, offered);
  if (!format) return std::unexpected(format.error());

  // Size: the configured one, or the largest the device offers.
  const auto sizes = offered_sizes(format->fourcc);
  cv::Size wanted(settings.width, settings.height);
  const bool largest = wanted.width <= 0 || wanted.height <= 0;
  if (largest) {
    wanted = {65535, 65535};  // the driver clamps this to its largest
    if (!sizes.empty())
      wanted = *std::max_element(sizes.begin(), sizes.end(),
                                 [](cv::Size a, cv::Size b) { return a.area() < b.area(); });
  }
  v4l2_format fmt{};
  fmt.type = kCapture;
  fmt.fmt.pix.width = static_cast<std::uint32_t>(wanted.width);
  fmt.fmt.pix.height = static_cast<std::uint32_t>(wanted.height);
  fmt.fmt.pix.pixelformat = format->fourcc;
  fmt.fmt.pix.field = V4L2_FIELD_NONE;
  if (xioctl(fd_, VIDIOC_S_FMT, &fmt) < 0) {
    const int e = errno;
    if (e == EINVAL)
      return std::unexpected(config_error(
          "camera.format", who() + " refuses " + fourcc_to_string(format->fourcc) + " " +
                               std::to_string(wanted.width) + "x" + std::to_string(wanted.height) +
                               ": it offers " + describe_offered(offered)));
    return std::unexpected(ioctl_error(device_, "setting the format", e));
  }
  if (fmt.fmt.pix.pixelformat != format->fourcc)
    return std::unexpected(config_error(
        "camera.format",
        who() + " gave " + fourcc_to_string(fmt.fmt.pix.pixelformat) + " when asked for " +
            fourcc_to_string(format->fourcc) +
            ": set camera.format to a format it offers: " + describe_offered(offered)));
  if (fmt.fmt.pix.field != V4L2_FIELD_NONE && fmt.fmt.pix.field != V4L2_FIELD_ANY)
    return std::unexpected(
        config_error("camera.format", who() + " delivers interlaced fields, which psrig cannot "
                                              "use: pick a progressive format or size"));
  const cv::Size got(static_cast<int>(fmt.fmt.pix.width), static_cast<int>(fmt.fmt.pix.height));
  if (!largest && got != wanted) {
    std::string list;
    for (const auto s : sizes)
      list += (list.empty() ? "" : ", ") + fmt::format("{}x{}", s.width, s.height);
    return std::unexpected(config_error(
        "camera.width",
        fmt::format("{} cannot deliver {}x{} in {} (nearest: {}x{}); sizes it "
                    "offers: {}; or set camera.width = camera.height = 0 for the "
                    "largest",
                    who(), wanted.width, wanted.height, fourcc_to_string(format->fourcc), got.width,
                    got.height, list.empty() ? "not listed" : list)));
  }
  format_ = *format;
  width_ = got.width;
  height_ = got.height;
  bytes_per_line_ =
      std::max<std::size_t>(fmt.fmt.pix.bytesperline, v4l2_min_bytes_per_line(format_, width_));

  frame_interval_ = std::chrono::nanoseconds{0};
  v4l2_streamparm parm{};
  parm.type = kCapture;
  if (xioctl(fd_, VIDIOC_G_PARM, &parm) == 0 &&
      (parm.parm.capture.capability & V4L2_CAP_TIMEPERFRAME) &&
      parm.parm.capture.timeperframe.denominator > 0)
    frame_interval_ = std::chrono::nanoseconds(
        static_cast<std::int64_t>(1e9 * parm.parm.capture.timeperframe.numerator /
                                  parm.parm.capture.timeperframe.denominator));

  auto set = v4l2::set_exposure_and_gain(fd_, device_, settings.exposure_us, settings.gain, width_);
  if (!set) return std::unexpected(set.error());
  exposure_us_ = set->exposure_us;
  gain_ = set->gain;
  if (frame_interval_.count() > 0 && std::chrono::microseconds(exposure_us_) > frame_interval_)
    logger("camera")->warn(
        "{}: exposure {} us is longer than the frame interval {} us: the camera may clip it or "
        "slow down",
        device_, exposure_us_,
        std::chrono::duration_cast<std::chrono::microseconds>(frame_interval_).count());
  configured_ = true;
  return {};
}

void V4l2Camera::release_buffers() {
  for (auto& b : buffers_)
    if (b.data != MAP_FAILED) ::munmap(b.data, b.length);
  buffers_.clear();
  v4l2_requestbuffers req{};
  req.count = 0;
  req.type = kCapture;
  req.memory = V4L2_MEMORY_MMAP;
  if (!vanished_) (void)xioctl(fd_, VIDIOC_REQBUFS, &req);
}

Status V4l2Camera::start() {
  if (!configured_)
    return std::unexpected(internal_error(device_ + ": start() before configure()"));
  if (streaming_) return {};
  if (vanished_) return std::unexpected(v4l2::vanished_error(device_, "starting"));
  v4l2_requestbuffers req{};
  req.count = kBufferCount;
  req.type = kCapture;
  req.memory = V4L2_MEMORY_MMAP;
  if (xioctl(fd_, VIDIOC_REQBUFS, &req) < 0)
    return std::unexpected(ioctl_error(device_, "requesting buffers", errno));
  if (req.count < 2) {
    release_buffers();
    return std::unexpected(io_error(
        device_, "the driver gave " + std::to_string(req.count) + " buffers, need 2 or more"));
  }
  const auto fail = [&](const std::string& step, int e) -> Status {
    release_buffers();
    return std::unexpected(ioctl_error(device_, step, e));
  };
  buffers_.resize(req.count);
  for (std::uint32_t i = 0; i < req.count; ++i) {
    v4l2_buffer buf{};
    buf.type = kCapture;
    buf.memory = V4L2_MEMORY_MMAP;
    buf.index = i;
    if (xioctl(fd_, VIDIOC_QUERYBUF, &buf) < 0) return fail("querying buffer", errno);
    void* data = ::mmap(nullptr, buf.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, buf.m.offset);
    if (data == MAP_FAILED) return fail("mapping buffer", errno);
    buffers_[i] = {data, buf.length};
    if (xioctl(fd_, VIDIOC_QBUF, &buf) < 0) return fail("queueing buffer", errno);
  }
  int type = kCapture;
  if (xioctl(fd_, VIDIOC_STREAMON, &type) < 0) {
    const int e = errno;
    if (e == ENOSPC) {
      release_buffers();
      return std::unexpected(
          io_error(device_,
                   "not enough USB bandwidth to stream: use a smaller camera.width/height or "
                   "plug the camera into another USB controller"));
    }
    return fail("starting the stream", e);
  }
  streaming_ = true;
  have_sequence_ = false;
  sequence_epoch_ = 0;
  return {};
}

Error V4l2Camera::timeout_error(std::chrono::milliseconds timeout, bool lost_frames) const {
  return io_error(device_, "no frame within " + std::to_string(timeout.count()) +
                               " ms (camera.timeout_ms)" +
                               (lost_frames ? ", the driver reported lost frames (EIO)" : "") +
                               ": check that the camera is connected and streaming and, if it is "
                               "triggered, its trigger");
}

Result<Frame> V4l2Camera::grab(std::chrono::milliseconds timeout) {
  if (!streaming_) return std::unexpected(internal_error(device_ + ": grab() before start()"));
  if (vanished_) return std::unexpected(v4l2::vanished_error(device_, "grabbing a frame"));
  const auto deadline = Clock::now() + timeout;
  bool lost_frames = false;
  for (;;) {
    const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - Clock::now());
    pollfd p{fd_, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(std::max<std::int64_t>(left.count(), 0)));
    if (ready < 0) {
      if (errno == EINTR) continue;
      return std::unexpected(ioctl_error(device_, "waiting for a frame", errno));
    }
    if (ready == 0) return std::unexpected(timeout_error(timeout, lost_frames));

    v4l2_buffer buf{};
    buf.type = kCapture;
    buf.memory = V4L2_MEMORY_MMAP;
    if (xioctl(fd_, VIDIOC_DQBUF, &buf) < 0) {
      const int e = errno;
      // EAGAIN: readiness without a frame; EIO: a lost frame (the driver may
      // still deliver the next). Both wait on, within the timeout.
      if (e == EAGAIN || e == EIO) {
        if (e == EIO) lost_frames = true;
        const auto now = Clock::now();
        if (now >= deadline) return std::unexpected(timeout_error(timeout, lost_frames));
        // Readiness without a frame again at once would spin: a spurious
        // wakeup, or a node that is always readable. Back off briefly.
        std::this_thread::sleep_for(std::min<Clock::duration>(kRetryPause, deadline - now));
        continue;
      }
      if (e == ENODEV) vanished_ = true;
      return std::unexpected(ioctl_error(device_, "dequeueing a frame", e));
    }
    if (buf.index >= buffers_.size())
      return std::unexpected(
          internal_error(device_ + ": the driver returned buffer " + std::to_string(buf.index)));

    const auto dequeued_at = Clock::now();
    Result<cv::Mat> image = cv::Mat{};
    const bool corrupt = buf.flags & V4L2_BUF_FLAG_ERROR;
    if (!corrupt) {
      const auto& b = buffers_[buf.index];
      const std::size_t used =
          buf.bytesused > 0 ? std::min<std::size_t>(buf.bytesused, b.length) : b.length;
      image = convert_v4l2_frame({static_cast<const std::uint8_t*>(b.data), used}, format_, width_,
                                 height_, bytes_per_line_);
    }
    // Back to the driver at once, whatever became of the frame.
    if (xioctl(fd_, VIDIOC_QBUF, &buf) < 0) {
      const int e = errno;
      if (e == ENODEV) vanished_ = true;
      return std::unexpected(ioctl_error(device_, "requeueing a buffer", e));
    }
    if (corrupt) continue;  // the driver says the data is damaged: wait for the next
    if (!image) {
      image.error().file = device_;
      return std::unexpected(image.error());
    }

    Frame frame;
    frame.image = std::move(*image);
    frame.exposure_us = exposure_us_;
    frame.gain = gain_;
    frame.white_level = format_.white_level();
    frame.black_level = 0;  // V4L2 does not report it: the dark frame measures it
    frame.encoding = format_.linear ? formats::Encoding::linear : formats::Encoding::srgb;
    frame.frame_interval = std::chrono::duration_cast<Clock::duration>(frame_interval_);

    // The driver's sequence is 32 bits; ours must not wrap.
    if (have_sequence_ && buf.sequence < last_sequence_) ++sequence_epoch_;
    have_sequence_ = true;
    last_sequence_ = buf.sequence;
    frame.sequence = (sequence_epoch_ << 32) | buf.sequence;

    // std::chrono::steady_clock is CLOCK_MONOTONIC on Linux (libstdc++), so
    // a monotonic buffer timestamp is a time_point on the LED switch log's clock.
    const auto exposure = std::chrono::microseconds(exposure_us_);
    Clock::time_point stamp = dequeued_at;
    if ((buf.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC)
      stamp = Clock::time_point(std::chrono::duration_cast<Clock::duration>(
          std::chrono::seconds(buf.timestamp.tv_sec) +
          std::chrono::microseconds(buf.timestamp.tv_usec)));
    if ((buf.flags & V4L2_BUF_FLAG_TSTAMP_SRC_MASK) == V4L2_BUF_FLAG_TSTAMP_SRC_SOE) {
      frame.exposure_start = stamp;
    } else {
      // End of frame: the exposure ended before the readout, which takes at
      // most a frame interval. Take the earliest start it can have had, so
      // the stale-frame rule errs towards throwing a frame away.
      const auto readout = frame_interval_.count() > 0
                               ? frame_interval_
                               : std::chrono::nanoseconds(kUnknownReadoutBound);
      frame.exposure_start =
          stamp - std::chrono::duration_cast<Clock::duration>(readout) - exposure;
    }
    frame.exposure_end = frame.exposure_start + exposure;
    return frame;
  }
}

Status V4l2Camera::stop() {
  if (!streaming_ && buffers_.empty()) return {};
  Status status;
  if (streaming_ && !vanished_) {
    int type = kCapture;
    if (xioctl(fd_, VIDIOC_STREAMOFF, &type) < 0) {
      const int e = errno;
      if (e == ENODEV)
        vanished_ = true;
      else
        status = std::unexpected(ioctl_error(device_, "stopping the stream", e));
    }
  }
  streaming_ = false;
  release_buffers();
  return status;
}

std::string V4l2Camera::describe() const {
  std::string s = "v4l2 " + who();
  if (configured_)
    s += fmt::format(", {}x{} {}, exposure {} us, gain {:.2f}", width_, height_,
                     fourcc_to_string(format_.fourcc), exposure_us_, gain_);
  return s;
}

}  // namespace

Result<std::unique_ptr<Camera>> open_v4l2_camera(const config::CameraConfig& config) {
  auto camera = std::make_unique<V4l2Camera>(config.device);
  if (auto opened = camera->open(); !opened) return std::unexpected(opened.error());
  return camera;
}

}  // namespace psrig::cameras
