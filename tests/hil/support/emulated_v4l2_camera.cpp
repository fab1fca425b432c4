#include "emulated_v4l2_camera.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <stdexcept>
#include <stdlib.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <opencv2/imgproc.hpp>

#include "v4l2_frame_encoder.h"

namespace psrig::test {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::microseconds;

timeval to_timeval(Clock::time_point t) {
  const auto us = std::chrono::duration_cast<microseconds>(t.time_since_epoch()).count();
  return timeval{static_cast<time_t>(us / 1'000'000), static_cast<suseconds_t>(us % 1'000'000)};
}

void copy_string(std::uint8_t* dst, std::size_t size, const std::string& s) {
  std::memset(dst, 0, size);
  std::memcpy(dst, s.data(), std::min(s.size(), size - 1));
}

std::string fourcc_text(std::uint32_t f) {
  std::string s;
  for (int i = 0; i < 4; ++i)
    s += static_cast<char>((f >> (8 * i)) & 0xff);
  return s;
}

// Integer controls take the nearest value in range and on a step, as the
// V4L2 control framework rounds them.
std::int32_t round_to_range(const EmulatedControl& c, std::int32_t value) {
  const std::int64_t step = std::max(c.step, 1);
  std::int64_t v = std::clamp<std::int64_t>(value, c.minimum, c.maximum);
  v = c.minimum + (v - c.minimum + step / 2) / step * step;
  return static_cast<std::int32_t>(std::min<std::int64_t>(v, c.maximum));
}

// The scene as the format is made from it: channels converted, 16 bits,
// values saturated to the format's range.
cv::Mat normalise_scene(const cv::Mat& image, const V4l2Encoding& encoding) {
  cv::Mat scene = image;
  if (scene.channels() == 3 && encoding.channels == 1)
    cv::cvtColor(scene, scene, cv::COLOR_BGR2GRAY);
  else if (scene.channels() == 1 && encoding.channels == 3)
    cv::cvtColor(scene, scene, cv::COLOR_GRAY2BGR);
  cv::Mat wide;
  scene.convertTo(wide, CV_16U);
  return cv::min(wide, (1 << encoding.bits) - 1);
}

}  // namespace

EmulatedV4l2Camera::EmulatedV4l2Camera(UmockdevBed& bed, EmulatedV4l2Options options,
                                       FrameSource source)
    : bed_(bed),
      options_(std::move(options)),
      source_(std::move(source)),
      fourcc_(options_.formats.at(0)),
      size_(options_.sizes.at(0)),
      exposure_(options_.exposure.default_value),
      gain_(options_.gain.default_value) {
  for (const auto f : options_.formats)
    if (!v4l2_encoding(f))
      throw std::invalid_argument("emulated camera: cannot make " + fourcc_text(f) + " frames");
  bed_.attach(devnode(), [this](UMockdevIoctlClient* client) { return handle(client); });
  // Contents make umockdev create the node as a regular file: the file
  // that QUERYBUF's offsets point into. Without, a PTY: pollable.
  const std::string devpath = options_.parent + "/video4linux/" + options_.name;
  bed_.add_from_string(
      "P: " + devpath + "\nN: " + options_.name + (options_.pollable ? "" : "=00") +
      "\nE: SUBSYSTEM=video4linux\nE: DEVNAME=/dev/" + options_.name +
      "\nE: MAJOR=81\nE: MINOR=" + std::to_string(options_.minor) +
      "\nA: dev=81:" + std::to_string(options_.minor) + "\nA: name=" + options_.card + "\n");
  syspath_ = "/sys" + devpath;
  if (options_.pollable) {
    pty_master_ = umockdev_testbed_get_dev_fd(bed_.testbed(), devnode().c_str());
    if (pty_master_ < 0)
      throw std::runtime_error("emulated camera: " + devnode() + " is not a PTY");
    // From the master, not by its /dev/pts path: umockdev takes a path
    // open of the PTY for one of the node, and would send our own reads
    // and ioctls on it to our handler.
    pty_slave_ = ::ioctl(pty_master_, TIOCGPTPEER, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (pty_slave_ < 0)
      throw std::runtime_error("emulated camera: cannot open the PTY of " + devnode() + ": " +
                               std::strerror(errno));
    // Raw: one byte in is one byte readable, nothing echoed back.
    termios raw{};
    ::tcgetattr(pty_slave_, &raw);
    ::cfmakeraw(&raw);
    ::tcsetattr(pty_slave_, TCSANOW, &raw);
    clock_ = std::thread([this] { run_clock(); });
    return;
  }
  const std::string backing = bed_.root() + "/dev/" + options_.name;
  backing_fd_ = ::open(backing.c_str(), O_RDWR | O_CLOEXEC);
  if (backing_fd_ < 0)
    throw std::runtime_error("emulated camera: cannot open " + backing + ": " +
                             std::strerror(errno));
}

EmulatedV4l2Camera::~EmulatedV4l2Camera() {
  {
    std::lock_guard lock(mutex_);
    closing_ = true;
  }
  clock_wake_.notify_all();
  if (clock_.joinable()) clock_.join();
  bed_.detach(devnode());
  release_buffers();
  if (backing_fd_ >= 0) ::close(backing_fd_);
  if (pty_slave_ >= 0) ::close(pty_slave_);
}

void EmulatedV4l2Camera::release_buffers() {
  for (auto& buffer : buffers_)
    if (buffer.fd >= 0) ::close(buffer.fd);
  buffers_.clear();
  queued_.clear();
  done_.clear();
}

// A byte waits in the PTY while a buffer is done: the caller's poll() says
// readable. It is put in and taken out only here, under the lock, and the
// device waits until the kernel has moved it (a PTY passes bytes on
// through a work queue), so readiness is never stale.
void EmulatedV4l2Camera::update_readiness() {
  if (!options_.pollable) return;
  const bool want = !done_.empty() && streaming_ && !unplugged_;
  if (want == readable_) return;
  const auto pending = [this] {
    int bytes = 0;
    ::ioctl(pty_slave_, FIONREAD, &bytes);
    return bytes;
  };
  const auto deadline = Clock::now() + std::chrono::milliseconds(500);
  if (want) {
    const char byte = 'f';
    if (::write(pty_master_, &byte, 1) != 1) return;
    while (pending() == 0 && Clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::microseconds(20));
  } else {
    char bytes[64];
    while (pending() > 0 && Clock::now() < deadline)
      if (::read(pty_slave_, bytes, sizeof bytes) <= 0)
        std::this_thread::sleep_for(std::chrono::microseconds(20));
  }
  readable_ = want;
}

// Pollable nodes: every frame is made when its buffer is due, whether or
// not the caller asks, and the caller's descriptor turns readable.
void EmulatedV4l2Camera::run_clock() {
  std::unique_lock lock(mutex_);
  while (!closing_) {
    if (!streaming_ || unplugged_ || stalled_at_) {
      clock_wake_.wait(lock);
      continue;
    }
    const auto due = frame_start(next_frame_) + exposure() + options_.readout;
    if (Clock::now() < due) {
      clock_wake_.wait_until(lock, due);
      continue;  // the plan may have changed
    }
    deliver_due(Clock::now());
    update_readiness();
  }
}

void EmulatedV4l2Camera::stall() {
  std::lock_guard lock(mutex_);
  stalled_at_ = Clock::now();
  clock_wake_.notify_all();
}

void EmulatedV4l2Camera::resume() {
  std::lock_guard lock(mutex_);
  if (!stalled_at_) return;
  stalled_at_.reset();
  // The sensor starts over from now; its frame count goes on.
  timeline_start_ = Clock::now();
  timeline_frame_ = next_frame_;
  clock_wake_.notify_all();
}

void EmulatedV4l2Camera::unplug() {
  bed_.on_bed_thread([this] {
    {
      std::lock_guard lock(mutex_);
      if (unplugged_) return;
      unplugged_ = true;
      streaming_ = false;
      update_readiness();
      clock_wake_.notify_all();
    }
    umockdev_testbed_uevent(bed_.testbed(), syspath_.c_str(), "remove");
    bed_.remove_device(syspath_);
  });
}

std::optional<std::int32_t> EmulatedV4l2Camera::control(std::uint32_t id) const {
  std::lock_guard lock(mutex_);
  return current_control(id);
}

std::optional<std::int32_t> EmulatedV4l2Camera::current_control(std::uint32_t id) const {
  if (id == V4L2_CID_EXPOSURE_AUTO && options_.auto_exposure) return exposure_auto_;
  if (id == options_.exposure.id) return exposure_;
  if (id == options_.gain.id) return gain_;
  return std::nullopt;
}

std::uint32_t EmulatedV4l2Camera::pixel_format() const {
  std::lock_guard lock(mutex_);
  return fourcc_;
}

cv::Size EmulatedV4l2Camera::size() const {
  std::lock_guard lock(mutex_);
  return size_;
}

bool EmulatedV4l2Camera::streaming() const {
  std::lock_guard lock(mutex_);
  return streaming_;
}

std::vector<FrameRequest> EmulatedV4l2Camera::delivered() const {
  std::lock_guard lock(mutex_);
  return delivered_;
}

int EmulatedV4l2Camera::dropped() const {
  std::lock_guard lock(mutex_);
  return dropped_;
}

std::size_t EmulatedV4l2Camera::bytes_per_line() const {
  return v4l2_line_bytes(fourcc_, size_.width) + options_.line_padding;
}

std::size_t EmulatedV4l2Camera::image_size() const {
  return bytes_per_line() * static_cast<std::size_t>(size_.height);
}

std::size_t EmulatedV4l2Camera::buffer_stride() const {
  const auto page = static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
  return (image_size() + page - 1) / page * page;
}

void EmulatedV4l2Camera::fill_format(v4l2_pix_format& pix) const {
  pix.width = static_cast<std::uint32_t>(size_.width);
  pix.height = static_cast<std::uint32_t>(size_.height);
  pix.pixelformat = fourcc_;
  pix.field = V4L2_FIELD_NONE;
  pix.bytesperline = static_cast<std::uint32_t>(bytes_per_line());
  pix.sizeimage = static_cast<std::uint32_t>(image_size());
  pix.colorspace = V4L2_COLORSPACE_RAW;
}

// As drivers do for TRY_FMT and S_FMT: an unknown format becomes the
// default, a size the nearest offered one; never an error.
void EmulatedV4l2Camera::adjust_format(v4l2_pix_format& pix) const {
  const auto& formats = options_.formats;
  if (std::find(formats.begin(), formats.end(), pix.pixelformat) == formats.end())
    pix.pixelformat = formats.front();
  const auto distance = [&](cv::Size s) {
    return std::abs(s.width - static_cast<int>(pix.width)) +
           std::abs(s.height - static_cast<int>(pix.height));
  };
  const cv::Size nearest =
      *std::min_element(options_.sizes.begin(), options_.sizes.end(),
                        [&](cv::Size a, cv::Size b) { return distance(a) < distance(b); });
  pix.width = static_cast<std::uint32_t>(nearest.width);
  pix.height = static_cast<std::uint32_t>(nearest.height);
  pix.field = V4L2_FIELD_NONE;
  const std::size_t line = v4l2_line_bytes(pix.pixelformat, nearest.width) + options_.line_padding;
  pix.bytesperline = static_cast<std::uint32_t>(line);
  pix.sizeimage = static_cast<std::uint32_t>(line * static_cast<std::size_t>(nearest.height));
  pix.colorspace = V4L2_COLORSPACE_RAW;
}

const EmulatedControl* EmulatedV4l2Camera::find_control(std::uint32_t id) const {
  if (id == options_.exposure.id) return &options_.exposure;
  if (id == options_.gain.id) return &options_.gain;
  return nullptr;
}

int EmulatedV4l2Camera::set_control(std::uint32_t id, std::int32_t value) {
  if (id == V4L2_CID_EXPOSURE_AUTO && options_.auto_exposure) {
    if (value < V4L2_EXPOSURE_AUTO || value > V4L2_EXPOSURE_APERTURE_PRIORITY) return EINVAL;
    exposure_auto_ = value;
    return 0;
  }
  const EmulatedControl* c = find_control(id);
  if (!c) return EINVAL;
  (id == options_.exposure.id ? exposure_ : gain_) = round_to_range(*c, value);
  return 0;
}

// Automatic exposure takes the whole frame interval; manual, the control.
std::chrono::microseconds EmulatedV4l2Camera::exposure() const {
  if (options_.auto_exposure && exposure_auto_ != V4L2_EXPOSURE_MANUAL)
    return options_.frame_interval;
  return microseconds(100) * exposure_;
}

// A frame period is the frame interval, or the exposure when that is longer.
Clock::time_point EmulatedV4l2Camera::frame_start(std::uint32_t frame) const {
  const auto period = std::max<Clock::duration>(options_.frame_interval, exposure());
  return timeline_start_ + period * (frame - timeline_frame_);
}

void EmulatedV4l2Camera::deliver_due(Clock::time_point now) {
  const auto limit = stalled_at_ ? std::min(now, *stalled_at_) : now;
  const auto exposure = this->exposure();
  for (;;) {
    const auto start = frame_start(next_frame_);
    if (start + exposure + options_.readout > limit) return;
    const std::uint32_t frame = next_frame_++;
    if (queued_.empty()) {
      ++dropped_;
      continue;
    }
    const std::size_t buffer = queued_.front();
    queued_.pop_front();
    deliver(frame, buffer);
  }
}

void EmulatedV4l2Camera::deliver(std::uint32_t frame, std::size_t buffer) {
  const auto exposure = this->exposure();
  const auto encoding = *v4l2_encoding(fourcc_);
  FrameRequest request;
  request.exposure_start = frame_start(frame);
  request.exposure_end = request.exposure_start + exposure;
  request.exposure_us = static_cast<int>(exposure.count());
  request.gain = static_cast<double>(gain_) / options_.gain.default_value;
  request.sequence = options_.first_sequence + frame;
  request.fourcc = fourcc_;
  request.width = size_.width;
  request.height = size_.height;
  request.channels = encoding.channels;
  request.bits = encoding.bits;

  std::uint32_t flags = V4L2_BUF_FLAG_MAPPED | V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC;
  flags |= options_.start_of_exposure_stamps ? V4L2_BUF_FLAG_TSTAMP_SRC_SOE
                                             : V4L2_BUF_FLAG_TSTAMP_SRC_EOF;
  const cv::Mat image = source_(request);
  if (image.size() != size_ || (image.depth() != CV_8U && image.depth() != CV_16U) ||
      (image.channels() != 1 && image.channels() != 3)) {
    // A test's mistake: say so, and hand out a buffer marked damaged.
    std::fprintf(stderr,
                 "emulated camera: the frame source gave a %dx%d image of type %d for %s %dx%d\n",
                 image.cols, image.rows, image.type(), fourcc_text(fourcc_).c_str(), size_.width,
                 size_.height);
    flags |= V4L2_BUF_FLAG_ERROR;
  } else {
    std::vector<std::uint8_t> bytes(image_size(), 0);
    encode_v4l2_frame(normalise_scene(image, encoding), fourcc_, bytes_per_line(), bytes);
    // A pollable node's buffers are files of their own.
    const int fd = options_.pollable ? buffers_[buffer].fd : backing_fd_;
    const auto offset = options_.pollable ? 0 : static_cast<off_t>(buffer * buffer_stride());
    if (::pwrite(fd, bytes.data(), bytes.size(), offset) != static_cast<ssize_t>(bytes.size())) {
      std::fprintf(stderr, "emulated camera: cannot write frame: %s\n", std::strerror(errno));
      flags |= V4L2_BUF_FLAG_ERROR;
    }
  }

  v4l2_buffer& b = buffers_[buffer].done;
  b = v4l2_buffer{};
  b.index = static_cast<std::uint32_t>(buffer);
  b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  b.bytesused = static_cast<std::uint32_t>(image_size());
  b.flags = flags;
  b.field = V4L2_FIELD_NONE;
  b.timestamp =
      to_timeval(options_.start_of_exposure_stamps ? request.exposure_start
                                                   : request.exposure_end + options_.readout);
  b.sequence = request.sequence;
  b.memory = memory_;
  if (memory_ == V4L2_MEMORY_DMABUF)
    b.m.fd = buffers_[buffer].queued_fd;
  else
    b.m.offset = static_cast<std::uint32_t>(buffer * buffer_stride());
  b.length = static_cast<std::uint32_t>(options_.pollable ? buffer_stride() : image_size());
  buffers_[buffer].owner = Owner::done;
  done_.push_back(buffer);
  delivered_.push_back(request);
}

bool EmulatedV4l2Camera::handle(UMockdevIoctlClient* client) {
  const unsigned long request = umockdev_ioctl_client_get_request(client);
  std::lock_guard lock(mutex_);
  // Gone: the V4L2 core answers ENODEV to whatever still holds the node.
  if (unplugged_) return answer(client, -1, ENODEV);
  const int error = serve(request, client);
  if (error < 0) return false;  // not a request we know: ENOTTY
  return error == 0 ? answer(client, 0) : answer(client, -1, error);
}

// Answers `request`, filling its argument; returns 0, an errno, or -1 for
// a request this device does not know.
int EmulatedV4l2Camera::serve(unsigned long request, UMockdevIoctlClient* client) {
  switch (request) {
    case VIDIOC_QUERYCAP: {
      Pointee<v4l2_capability> cap(client);
      *cap = v4l2_capability{};
      copy_string(cap->driver, sizeof cap->driver, options_.driver);
      copy_string(cap->card, sizeof cap->card, options_.card);
      copy_string(cap->bus_info, sizeof cap->bus_info, options_.bus_info);
      cap->version = (6u << 16) | (1u << 8);
      cap->device_caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING;
      cap->capabilities = cap->device_caps | V4L2_CAP_DEVICE_CAPS;
      return 0;
    }
    case VIDIOC_ENUM_FMT: {
      Pointee<v4l2_fmtdesc> d(client);
      if (d->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || d->index >= options_.formats.size())
        return EINVAL;
      const std::uint32_t index = d->index;
      *d = v4l2_fmtdesc{};
      d->index = index;
      d->type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      d->pixelformat = options_.formats[index];
      copy_string(d->description, sizeof d->description, "emulated " + fourcc_text(d->pixelformat));
      return 0;
    }
    case VIDIOC_ENUM_FRAMESIZES: {
      Pointee<v4l2_frmsizeenum> s(client);
      const auto& formats = options_.formats;
      if (std::find(formats.begin(), formats.end(), s->pixel_format) == formats.end() ||
          s->index >= options_.sizes.size())
        return EINVAL;
      s->type = V4L2_FRMSIZE_TYPE_DISCRETE;
      s->discrete.width = static_cast<std::uint32_t>(options_.sizes[s->index].width);
      s->discrete.height = static_cast<std::uint32_t>(options_.sizes[s->index].height);
      return 0;
    }
    case VIDIOC_G_FMT: {
      Pointee<v4l2_format> f(client);
      if (f->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return EINVAL;
      fill_format(f->fmt.pix);
      return 0;
    }
    case VIDIOC_TRY_FMT:
    case VIDIOC_S_FMT: {
      Pointee<v4l2_format> f(client);
      if (f->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return EINVAL;
      if (request == VIDIOC_S_FMT && !buffers_.empty()) return EBUSY;
      adjust_format(f->fmt.pix);
      if (request == VIDIOC_S_FMT) {
        fourcc_ = f->fmt.pix.pixelformat;
        size_ = cv::Size(static_cast<int>(f->fmt.pix.width), static_cast<int>(f->fmt.pix.height));
      }
      return 0;
    }
    case VIDIOC_G_PARM: {
      Pointee<v4l2_streamparm> p(client);
      if (p->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return EINVAL;
      p->parm.capture = v4l2_captureparm{};
      p->parm.capture.capability = V4L2_CAP_TIMEPERFRAME;
      p->parm.capture.timeperframe.numerator =
          static_cast<std::uint32_t>(options_.frame_interval.count());
      p->parm.capture.timeperframe.denominator = 1'000'000;
      return 0;
    }
    case VIDIOC_REQBUFS:
    case VIDIOC_QUERYBUF:
    case VIDIOC_QBUF:
    case VIDIOC_DQBUF:
    case VIDIOC_EXPBUF:
    case VIDIOC_STREAMON:
    case VIDIOC_STREAMOFF:
      return serve_buffer(request, client);
    case VIDIOC_QUERY_EXT_CTRL:
    case VIDIOC_QUERYMENU:
    case VIDIOC_G_EXT_CTRLS:
    case VIDIOC_S_EXT_CTRLS:
      return serve_ext_controls(request, client);
    case VIDIOC_QUERYCTRL: {
      Pointee<v4l2_queryctrl> q(client);
      const std::uint32_t id = q->id;
      *q = v4l2_queryctrl{};
      q->id = id;
      if (id == V4L2_CID_EXPOSURE_AUTO && options_.auto_exposure) {
        q->type = V4L2_CTRL_TYPE_MENU;
        copy_string(q->name, sizeof q->name, "Auto Exposure");
        q->minimum = V4L2_EXPOSURE_AUTO;
        q->maximum = V4L2_EXPOSURE_APERTURE_PRIORITY;
        q->step = 1;
        q->default_value = V4L2_EXPOSURE_APERTURE_PRIORITY;
        return 0;
      }
      const EmulatedControl* c = find_control(id);
      if (!c) return EINVAL;
      q->type = V4L2_CTRL_TYPE_INTEGER;
      copy_string(q->name, sizeof q->name, id == options_.gain.id ? "Gain" : "Exposure");
      q->minimum = c->minimum;
      q->maximum = c->maximum;
      q->step = c->step;
      q->default_value = c->default_value;
      return 0;
    }
    case VIDIOC_G_CTRL: {
      Pointee<v4l2_control> c(client);
      const auto value = current_control(c->id);
      if (!value) return EINVAL;
      c->value = *value;
      return 0;
    }
    case VIDIOC_S_CTRL: {
      Pointee<v4l2_control> c(client);
      const int error = set_control(c->id, c->value);
      if (error == 0) c->value = *current_control(c->id);
      return error;
    }
    default:
      return -1;
  }
}

// The buffer queue: REQBUFS to STREAMOFF.
int EmulatedV4l2Camera::serve_buffer(unsigned long request, UMockdevIoctlClient* client) {
  switch (request) {
    case VIDIOC_REQBUFS: {
      Pointee<v4l2_requestbuffers> r(client);
      const bool dmabuf = options_.pollable && r->memory == V4L2_MEMORY_DMABUF;
      if (r->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || (r->memory != V4L2_MEMORY_MMAP && !dmabuf))
        return EINVAL;
      if (streaming_) return EBUSY;
      release_buffers();
      update_readiness();
      memory_ = r->memory;
      r->capabilities =
          V4L2_BUF_CAP_SUPPORTS_MMAP | (options_.pollable ? V4L2_BUF_CAP_SUPPORTS_DMABUF : 0u);
      if (r->count == 0) return 0;
      r->count = std::clamp<std::uint32_t>(r->count, 2, 8);
      buffers_.resize(r->count);
      if (options_.pollable) {
        if (dmabuf) return 0;  // the caller brings them, with QBUF
        // One memfd a buffer, which EXPBUF hands out.
        for (auto& buffer : buffers_) {
          buffer.fd = ::memfd_create("psrig-emulated-buffer", MFD_CLOEXEC);
          if (buffer.fd < 0 || ::ftruncate(buffer.fd, static_cast<off_t>(buffer_stride())) < 0) {
            release_buffers();
            return ENOMEM;
          }
        }
        return 0;
      }
      // Room in the backing file for every buffer, so that mapping works.
      const auto needed = static_cast<off_t>(buffer_stride() * r->count);
      struct stat st {};
      if (::fstat(backing_fd_, &st) == 0 && st.st_size < needed &&
          ::ftruncate(backing_fd_, needed) < 0)
        return ENOMEM;
      return 0;
    }
    case VIDIOC_EXPBUF: {
      Pointee<v4l2_exportbuffer> e(client);
      if (!options_.pollable || e->type != V4L2_BUF_TYPE_VIDEO_CAPTURE ||
          memory_ != V4L2_MEMORY_MMAP || e->index >= buffers_.size() || e->plane != 0)
        return EINVAL;
      // The caller is this process: a duplicate is its descriptor too.
      const int fd =
          ::fcntl(buffers_[e->index].fd, (e->flags & O_CLOEXEC) ? F_DUPFD_CLOEXEC : F_DUPFD, 0);
      if (fd < 0) return errno;
      e->fd = fd;
      return 0;
    }
    case VIDIOC_QUERYBUF:
    case VIDIOC_QBUF:
    case VIDIOC_DQBUF: {
      Pointee<v4l2_buffer> b(client);
      // Only QBUF must name the queue's memory, as vb2 checks it.
      if (b->type != V4L2_BUF_TYPE_VIDEO_CAPTURE ||
          (request == VIDIOC_QBUF && b->memory != memory_))
        return EINVAL;
      if (request == VIDIOC_DQBUF) {
        if (!streaming_) return EINVAL;
        deliver_due(Clock::now());
        if (done_.empty()) return EAGAIN;
        const std::size_t index = done_.front();
        done_.pop_front();
        buffers_[index].owner = Owner::caller;
        *b = buffers_[index].done;
        update_readiness();
        return 0;
      }
      if (b->index >= buffers_.size()) return EINVAL;
      Buffer& buffer = buffers_[b->index];
      if (request == VIDIOC_QBUF) {
        if (buffer.owner != Owner::caller) return EINVAL;
        if (memory_ == V4L2_MEMORY_DMABUF) {
          // Imported: keep it open while queued, as the kernel holds a
          // reference to the dmabuf.
          struct stat st {};
          if (::fstat(b->m.fd, &st) < 0 || st.st_size < static_cast<off_t>(image_size()))
            return EINVAL;
          if (buffer.fd >= 0) ::close(buffer.fd);
          buffer.fd = ::fcntl(b->m.fd, F_DUPFD_CLOEXEC, 0);
          if (buffer.fd < 0) return errno;
          buffer.queued_fd = b->m.fd;
        }
        buffer.owner = Owner::queued;
        queued_.push_back(b->index);
        b->flags = (b->flags & ~V4L2_BUF_FLAG_DONE) | V4L2_BUF_FLAG_MAPPED | V4L2_BUF_FLAG_QUEUED;
        return 0;
      }
      const std::uint32_t index = b->index;
      *b = v4l2_buffer{};
      b->index = index;
      b->type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      b->memory = memory_;
      b->m.offset = static_cast<std::uint32_t>(index * buffer_stride());
      // A pollable node's buffers are whole pages: what an exported one maps.
      b->length = static_cast<std::uint32_t>(options_.pollable ? buffer_stride() : image_size());
      b->flags = V4L2_BUF_FLAG_MAPPED | V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC |
                 (buffer.owner == Owner::queued ? V4L2_BUF_FLAG_QUEUED : 0u) |
                 (buffer.owner == Owner::done ? V4L2_BUF_FLAG_DONE : 0u);
      return 0;
    }
    case VIDIOC_STREAMON:
    case VIDIOC_STREAMOFF: {
      Pointee<int> type(client);
      if (*type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return EINVAL;
      if (request == VIDIOC_STREAMON) {
        if (buffers_.empty()) return EINVAL;
        if (!streaming_) {
          streaming_ = true;
          timeline_start_ = Clock::now();
          timeline_frame_ = 0;
          next_frame_ = 0;
          clock_wake_.notify_all();
        }
        return 0;
      }
      // Off: every buffer back to the caller, done or not.
      streaming_ = false;
      queued_.clear();
      done_.clear();
      for (auto& buffer : buffers_)
        buffer.owner = Owner::caller;
      update_readiness();
      clock_wake_.notify_all();
      return 0;
    }
    default:
      return -1;
  }
}

// The extended controls, over the same exposure, gain and auto-exposure
// controls VIDIOC_QUERYCTRL describes.
int EmulatedV4l2Camera::serve_ext_controls(unsigned long request, UMockdevIoctlClient* client) {
  std::vector<std::uint32_t> ids;
  if (options_.auto_exposure) ids.push_back(V4L2_CID_EXPOSURE_AUTO);
  ids.push_back(options_.exposure.id);
  ids.push_back(options_.gain.id);
  std::sort(ids.begin(), ids.end());
  switch (request) {
    case VIDIOC_QUERY_EXT_CTRL: {
      Pointee<v4l2_query_ext_ctrl> q(client);
      const std::uint32_t asked =
          q->id & ~(V4L2_CTRL_FLAG_NEXT_CTRL | V4L2_CTRL_FLAG_NEXT_COMPOUND);
      const bool next = q->id & (V4L2_CTRL_FLAG_NEXT_CTRL | V4L2_CTRL_FLAG_NEXT_COMPOUND);
      std::optional<std::uint32_t> id;
      for (const auto candidate : ids)
        if (next ? candidate > asked : candidate == asked) {
          id = candidate;
          break;
        }
      if (!id) return EINVAL;
      *q = v4l2_query_ext_ctrl{};
      q->id = *id;
      q->elem_size = sizeof(std::int32_t);
      q->elems = 1;
      if (*id == V4L2_CID_EXPOSURE_AUTO) {
        q->type = V4L2_CTRL_TYPE_MENU;
        copy_string(reinterpret_cast<std::uint8_t*>(q->name), sizeof q->name, "Auto Exposure");
        q->minimum = V4L2_EXPOSURE_AUTO;
        q->maximum = V4L2_EXPOSURE_APERTURE_PRIORITY;
        q->step = 1;
        q->default_value = V4L2_EXPOSURE_APERTURE_PRIORITY;
        return 0;
      }
      const EmulatedControl* c = find_control(*id);
      q->type = V4L2_CTRL_TYPE_INTEGER;
      copy_string(reinterpret_cast<std::uint8_t*>(q->name), sizeof q->name,
                  *id == options_.gain.id ? "Gain" : "Exposure");
      q->minimum = c->minimum;
      q->maximum = c->maximum;
      q->step = static_cast<std::uint64_t>(c->step);
      q->default_value = c->default_value;
      return 0;
    }
    case VIDIOC_QUERYMENU: {
      Pointee<v4l2_querymenu> m(client);
      // As a UVC camera: manual and aperture priority only.
      if (m->id != V4L2_CID_EXPOSURE_AUTO || !options_.auto_exposure ||
          (m->index != V4L2_EXPOSURE_MANUAL && m->index != V4L2_EXPOSURE_APERTURE_PRIORITY))
        return EINVAL;
      const char* name =
          m->index == V4L2_EXPOSURE_MANUAL ? "Manual Mode" : "Aperture Priority Mode";
      std::memset(m->name, 0, sizeof m->name);
      std::memcpy(m->name, name, std::strlen(name));
      return 0;
    }
    case VIDIOC_G_EXT_CTRLS:
    case VIDIOC_S_EXT_CTRLS: {
      Pointee<v4l2_ext_controls> list(client);
      if (list->count == 0) return 0;
      if (list->count > 64) return EINVAL;
      const std::uint32_t count = list->count;
      UMockdevIoctlData* array =
          umockdev_ioctl_data_resolve(list.data(), offsetof(v4l2_ext_controls, controls),
                                      sizeof(v4l2_ext_control) * count, nullptr);
      if (!array) return EFAULT;
      int error = 0;
      for (std::uint32_t i = 0; i < count && !error; ++i) {
        v4l2_ext_control c{};
        std::memcpy(&c, array->data + i * sizeof c, sizeof c);
        if (request == VIDIOC_S_EXT_CTRLS) error = set_control(c.id, c.value);
        if (!error) {
          const auto value = current_control(c.id);
          if (!value)
            error = EINVAL;
          else
            c.value = *value;
        }
        if (error)
          list->error_idx = i;
        else
          std::memcpy(array->data + i * sizeof c, &c, sizeof c);
      }
      umockdev_ioctl_data_unref(array);
      clock_wake_.notify_all();  // a new exposure moves the next frame
      return error;
    }
    default:
      return -1;
  }
}

}  // namespace psrig::test
