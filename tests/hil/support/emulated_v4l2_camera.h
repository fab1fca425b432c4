#pragma once
// An emulated V4L2 capture device for hardware-in-the-loop tests: the real
// v4l2 backend opens /dev/<name>, negotiates a format, sets its controls,
// maps its buffers and streams from it, while this class answers as a
// driver would. Its frames come from a callback, so a test can draw known
// pixel values or render the simulated world.
//
// How it sits on umockdev 0.17 (Debian 12), and where that differs from a
// kernel driver:
//
// - ioctl: the preload library forwards every ioctl on the node to our
//   handler (UmockdevBed), which reads and writes the caller's structs.
// - mmap: not intercepted (the preload library wraps no mmap()), so the
//   caller maps the node's backing file itself. umockdev makes a node a
//   regular file only when its description gives it contents (`N:
//   video0=00`); without, it is a PTY, which cannot be mapped. We size that
//   file to hold every buffer, hand out page-aligned offsets into it from
//   QUERYBUF and write each frame into the file at its buffer's offset:
//   MAP_SHARED pages are the file's page cache, so the caller sees the
//   frame once it has dequeued the buffer, as with a driver's buffers.
// - poll: not intercepted either, and a regular file is always readable,
//   so poll() cannot wait for a frame here. Readiness shows only in DQBUF,
//   which answers EAGAIN while no buffer is done, as a driver does for a
//   non-blocking descriptor (every caller here opens it so); the camera's
//   retry after a readiness without a frame does the waiting. So a test can
//   check that grab() times out and when, but not that it slept in poll().
// - stat: the preload library reports the node as a character device to
//   stat() by path, not to fstat() (0.17 wraps no fstat), where it stays a
//   regular file.
// - unplug(): every later request fails with ENODEV, as the V4L2 core
//   answers for a device that was unregistered, and the device leaves the
//   testbed (sysfs and /dev) after a "remove" uevent. Mappings stay valid,
//   as a driver's do until unmapped. A kernel node polls POLLERR|POLLHUP
//   from then on; a pollable one here just stays unreadable.
//
// - A pollable node (EmulatedV4l2Options::pollable, for libcamera, whose
//   event loop waits in ppoll() and maps only exported buffers) is a PTY
//   instead: no mmap of the node, but a real descriptor that poll() can
//   wait on. The device makes the caller's descriptor readable, as a
//   driver does, exactly while a buffer is done and not yet dequeued, by
//   writing a byte into the PTY's master side and reading it back out on
//   its own descriptor of the slave side. Frames are then made on a clock
//   thread of the device's own when they are due, not when the caller asks.
//   Its MMAP buffers are memfds that VIDIOC_EXPBUF hands out as dmabufs
//   (the caller is this process, so the descriptor is valid there), and it
//   takes V4L2_MEMORY_DMABUF buffers, writing each frame into the
//   descriptor queued with it (any file it can pwrite: memfds included).
//   The extended controls (QUERY_EXT_CTRL, G/S_EXT_CTRLS, QUERYMENU) are
//   served in both kinds.
//
// Frames run in real time on the steady clock from STREAMON: frame n's
// exposure starts at n frame periods (the longer of frame_interval and the
// exposure) and its buffer is done `readout` after the exposure ends. They
// are produced when the caller asks (DQBUF): every frame done by then goes,
// in order, into the oldest queued buffer, or is dropped when none is
// queued (its sequence number is used all the same), which is what a
// driver's queue does in real time. The callback runs on umockdev's
// handler thread while the caller waits in DQBUF.

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <linux/videodev2.h>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include "umockdev_bed.h"

namespace psrig::test {

// One frame the device is about to deliver, for the frame callback.
struct FrameRequest {
  std::chrono::steady_clock::time_point exposure_start;
  std::chrono::steady_clock::time_point exposure_end;
  int exposure_us = 0;  // as the device applies it
  double gain = 1.0;    // the gain control over its default (unity)
  std::uint32_t sequence = 0;
  std::uint32_t fourcc = 0;  // the negotiated pixel format
  int width = 0;
  int height = 0;
  int channels = 1;  // what the format is made from: 1 grey, 3 BGR (colour and Bayer)
  int bits = 8;      // its significant bits: values run from 0 to 2^bits - 1
};

// Returns the scene as the sensor sees it: width x height, CV_8U or CV_16U,
// 1 or 3 channels (converted when they differ from `channels`), values in
// the format's range (larger ones saturate). It runs with the device's
// lock held, so it must not call the EmulatedV4l2Camera back.
using FrameSource = std::function<cv::Mat(const FrameRequest&)>;

// An integer control as VIDIOC_QUERYCTRL describes it.
struct EmulatedControl {
  std::uint32_t id = 0;
  std::int32_t minimum = 0;
  std::int32_t maximum = 0;
  std::int32_t step = 1;
  std::int32_t default_value = 0;
};

struct EmulatedV4l2Options {
  std::string name = "video0";  // the node is /dev/<name>
  std::string card = "psrig emulated camera";
  std::string driver = "psrig-emulated";
  std::string bus_info = "platform:psrig-emulated-camera";
  // The sysfs device the node hangs under, without /sys.
  std::string parent = "/devices/platform/psrig-emulated-camera";
  std::uint32_t minor = 0;  // the node is char 81:minor
  // A PTY that poll() waits on, exported and imported dmabufs (above).
  bool pollable = false;
  // Offered pixel formats, in VIDIOC_ENUM_FMT order; the first is the default.
  std::vector<std::uint32_t> formats{V4L2_PIX_FMT_GREY};
  // Offered sizes (discrete); the first is the default.
  std::vector<cv::Size> sizes{{32, 24}};
  std::size_t line_padding = 0;  // bytes after each line's pixels
  std::chrono::microseconds frame_interval{10'000};
  std::chrono::microseconds readout{2'000};  // exposure end to buffer done
  // V4L2_BUF_FLAG_TSTAMP_SRC_SOE: stamped at the start of exposure; else
  // _EOF: stamped when the buffer is done.
  bool start_of_exposure_stamps = true;
  std::uint32_t first_sequence = 0;
  // V4L2_CID_EXPOSURE_AUTO (a menu, default aperture priority) beside the
  // exposure; while not manual the device exposes for a whole frame interval.
  bool auto_exposure = true;
  // V4L2_CID_EXPOSURE_ABSOLUTE, in 100 us.
  EmulatedControl exposure{V4L2_CID_EXPOSURE_ABSOLUTE, 1, 5000, 1, 100};
  // V4L2_CID_GAIN or V4L2_CID_ANALOGUE_GAIN; its default is unity.
  EmulatedControl gain{V4L2_CID_GAIN, 16, 255, 1, 16};
};

class EmulatedV4l2Camera {
 public:
  // Adds /dev/<name> and its sysfs device to `bed` and serves it.
  EmulatedV4l2Camera(UmockdevBed& bed, EmulatedV4l2Options options, FrameSource source);
  ~EmulatedV4l2Camera();
  EmulatedV4l2Camera(const EmulatedV4l2Camera&) = delete;
  EmulatedV4l2Camera& operator=(const EmulatedV4l2Camera&) = delete;

  [[nodiscard]] std::string devnode() const { return "/dev/" + options_.name; }
  [[nodiscard]] std::string syspath() const { return syspath_; }
  [[nodiscard]] std::uint32_t minor() const { return options_.minor; }

  // The sensor stops: no frame whose buffer would be done after now is
  // delivered until resume(), from when frames run on as after STREAMON
  // (their sequence numbers carrying on).
  void stall();
  void resume();
  // The device vanishes (unplugged, driver unbound).
  void unplug();

  // What the caller has set.
  [[nodiscard]] std::optional<std::int32_t> control(std::uint32_t id) const;
  [[nodiscard]] std::uint32_t pixel_format() const;
  [[nodiscard]] cv::Size size() const;
  [[nodiscard]] bool streaming() const;
  // Every frame put into a buffer so far, in order.
  [[nodiscard]] std::vector<FrameRequest> delivered() const;
  // Frames dropped because no buffer was queued.
  [[nodiscard]] int dropped() const;

 private:
  enum class Owner { caller, queued, done };
  struct Buffer {
    Owner owner = Owner::caller;
    v4l2_buffer done{};  // what DQBUF reports once the buffer is done
    // Pollable nodes: the buffer's memfd (MMAP), or a duplicate of the
    // dmabuf queued with it (DMABUF); frames are written there at 0.
    int fd = -1;
    std::int32_t queued_fd = -1;  // the caller's number for it, for DQBUF
  };

  bool handle(UMockdevIoctlClient* client);
  int serve(unsigned long request, UMockdevIoctlClient* client);
  void fill_format(v4l2_pix_format& pix) const;
  void adjust_format(v4l2_pix_format& pix) const;
  std::size_t bytes_per_line() const;
  std::size_t image_size() const;
  std::size_t buffer_stride() const;  // buffer size rounded up to pages
  const EmulatedControl* find_control(std::uint32_t id) const;
  int set_control(std::uint32_t id, std::int32_t value);
  std::optional<std::int32_t> current_control(std::uint32_t id) const;
  std::chrono::microseconds exposure() const;
  std::chrono::steady_clock::time_point frame_start(std::uint32_t frame) const;
  void deliver_due(std::chrono::steady_clock::time_point now);
  void deliver(std::uint32_t frame, std::size_t buffer);
  int serve_buffer(unsigned long request, UMockdevIoctlClient* client);
  int serve_ext_controls(unsigned long request, UMockdevIoctlClient* client);
  void release_buffers();
  // Pollable nodes: the caller's descriptor readable while a buffer is done.
  void update_readiness();
  void run_clock();

  UmockdevBed& bed_;
  EmulatedV4l2Options options_;
  FrameSource source_;
  std::string syspath_;
  int backing_fd_ = -1;  // the node's file, which the caller maps
  int pty_master_ = -1;  // pollable: umockdev's side of the node
  int pty_slave_ = -1;   // pollable: ours, to take the readiness byte back
  bool readable_ = false;
  std::uint32_t memory_ = V4L2_MEMORY_MMAP;  // of the buffers REQBUFS made

  mutable std::mutex mutex_;
  std::uint32_t fourcc_;
  cv::Size size_;
  std::int32_t exposure_auto_ = V4L2_EXPOSURE_APERTURE_PRIORITY;
  std::int32_t exposure_;
  std::int32_t gain_;
  std::vector<Buffer> buffers_;
  std::deque<std::size_t> queued_;  // in QBUF order
  std::deque<std::size_t> done_;
  bool streaming_ = false;
  bool unplugged_ = false;
  std::optional<std::chrono::steady_clock::time_point> stalled_at_;
  // Frame timeline_frame_ starts its exposure at timeline_start_ (STREAMON,
  // or the end of a stall), each later one a frame period after the last.
  std::chrono::steady_clock::time_point timeline_start_;
  std::uint32_t timeline_frame_ = 0;
  std::uint32_t next_frame_ = 0;  // frames since STREAMON, delivered or dropped
  std::vector<FrameRequest> delivered_;
  int dropped_ = 0;
  // Pollable nodes: makes frames when due; woken on every change of plan.
  std::condition_variable clock_wake_;
  bool closing_ = false;
  std::thread clock_;
};

}  // namespace psrig::test
