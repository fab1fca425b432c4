#include "psrig/cameras/libcamera_camera.h"

#include <cerrno>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <libcamera/libcamera.h>
#include <map>
#include <mutex>
#include <span>
#include <sys/mman.h>
#include <time.h>

#include "psrig/base/log.h"
#include "psrig/cameras/v4l2_formats.h"

// Written against libcamera 0.0.3 (Debian 12). Later releases changed:
// - 0.5 replaced AeEnable by ExposureTimeMode and AnalogueGainMode (guarded
//   below);
// - ControlList::get() already returns std::optional from 0.0.1 on, as used.
#define PSRIG_LIBCAMERA_AT_LEAST(major, minor) \
  (LIBCAMERA_VERSION_MAJOR > (major) ||        \
   (LIBCAMERA_VERSION_MAJOR == (major) && LIBCAMERA_VERSION_MINOR >= (minor)))

namespace psrig::cameras {
namespace {

namespace lc = libcamera;
using namespace std::chrono;

// libcamera allows one camera manager per process: cameras and the device
// listing share it, and it stops when the last of them lets go.
Result<std::shared_ptr<lc::CameraManager>> camera_manager() {
  static std::mutex mutex;
  static std::weak_ptr<lc::CameraManager> shared;
  std::lock_guard lock(mutex);
  if (auto manager = shared.lock()) return manager;
  // libcamera logs every pipeline it probes; an engineer can still ask for
  // that through LIBCAMERA_LOG_LEVELS.
  setenv("LIBCAMERA_LOG_LEVELS", "*:ERROR", /*overwrite=*/0);
  auto manager = std::make_shared<lc::CameraManager>();
  if (const int result = manager->start(); result < 0)
    return std::unexpected(io_error(
        "libcamera", std::string("the camera manager did not start: ") + std::strerror(-result)));
  shared = manager;
  return manager;
}

std::optional<V4l2PixelFormat> v4l2_equivalent(const lc::PixelFormat& format) {
  return v4l2_format_for_libcamera(format.toString());
}

std::int64_t clock_ns(clockid_t clock) {
  timespec now{};
  clock_gettime(clock, &now);
  return now.tv_sec * 1'000'000'000LL + now.tv_nsec;
}

// libcamera documents SensorTimestamp on CLOCK_BOOTTIME, while pipelines fill
// it from the V4L2 buffer's CLOCK_MONOTONIC; the two differ by the time the
// board has slept. Take whichever clock the stamp is just behind.
Clock::time_point on_steady_clock(std::int64_t sensor_ns) {
  const std::int64_t monotonic = clock_ns(CLOCK_MONOTONIC);
  const std::int64_t boot = clock_ns(CLOCK_BOOTTIME);
  const std::int64_t behind_monotonic = monotonic - sensor_ns, behind_boot = boot - sensor_ns;
  const bool boot_based =
      behind_boot >= 0 && (behind_monotonic < 0 || behind_boot < behind_monotonic);
  const std::int64_t steady_ns = boot_based ? sensor_ns - (boot - monotonic) : sensor_ns;
  return Clock::time_point(duration_cast<Clock::duration>(nanoseconds(steady_ns)));
}

std::string camera_label(const std::shared_ptr<lc::Camera>& camera) {
  std::string label = camera->id();
  if (const auto model = camera->properties().get(lc::properties::Model))
    label += " (" + *model + ")";
  return label;
}

// A buffer's first plane mapped into our memory.
struct MappedBuffer {
  void* base = MAP_FAILED;
  std::size_t length = 0;
  std::span<const std::uint8_t> plane;
};

class LibcameraCamera final : public Camera {
 public:
  LibcameraCamera(std::shared_ptr<lc::CameraManager> manager, std::shared_ptr<lc::Camera> camera)
      : manager_(std::move(manager)), camera_(std::move(camera)) {
    camera_->disconnected.connect(this, &LibcameraCamera::disconnected);
  }

  ~LibcameraCamera() override {
    (void)stop();
    release_buffers();
    camera_->disconnected.disconnect(this);
    camera_->release();
    camera_.reset();  // before the manager goes
  }

  Status configure(const config::CameraConfig& settings) override {
    if (running_)
      return std::unexpected(internal_error(describe() + ": configure while streaming"));
    release_buffers();
    settings_ = settings;

    std::optional<V4l2PixelFormat> wanted;
    if (settings.format != "auto") {
      wanted = find_v4l2_format(settings.format);
      if (!wanted)
        return std::unexpected(
            bad_input(settings.device, "camera.format",
                      "\"" + settings.format + "\" is not a pixel format psrig converts"));
    }
    // Photometric stereo wants the sensor's raw, linear data; an ISP's
    // processed output only when asked for by name.
    const lc::StreamRole role =
        !wanted || wanted->linear ? lc::StreamRole::Raw : lc::StreamRole::StillCapture;
    configuration_ = camera_->generateConfiguration({role});
    if (!configuration_ || configuration_->empty())
      return std::unexpected(io_error(label(), role == lc::StreamRole::Raw
                                                   ? "offers no raw stream (camera.format)"
                                                   : "offers no still stream"));
    lc::StreamConfiguration& stream = configuration_->at(0);
    if (settings.width > 0 && settings.height > 0)
      stream.size =
          lc::Size(static_cast<unsigned>(settings.width), static_cast<unsigned>(settings.height));
    auto chosen = choose_format(stream, wanted);
    if (!chosen) return std::unexpected(chosen.error());
    stream.pixelFormat = *chosen;
    stream.bufferCount = std::max(stream.bufferCount, 4U);

    if (configuration_->validate() == lc::CameraConfiguration::Invalid)
      return std::unexpected(
          io_error(label(), "refused the configuration " + stream.toString() +
                                " (camera.width, camera.height, camera.format)"));
    if (stream.pixelFormat != *chosen)
      return std::unexpected(io_error(label(), "cannot deliver " + chosen->toString() + " at " +
                                                   stream.size.toString() + " (camera.format)"));
    if (settings.width > 0 && (stream.size.width != static_cast<unsigned>(settings.width) ||
                               stream.size.height != static_cast<unsigned>(settings.height)))
      logger("camera")->warn("{}: {}x{} adjusted to {} (camera.width, camera.height)", label(),
                             settings.width, settings.height, stream.size.toString());
    if (const int result = camera_->configure(configuration_.get()); result < 0)
      return std::unexpected(
          io_error(label(), std::string("configure: ") + std::strerror(-result)));

    format_ = *v4l2_equivalent(stream.pixelFormat);
    width_ = static_cast<int>(stream.size.width);
    height_ = static_cast<int>(stream.size.height);
    stride_ = stream.stride;
    return allocate(stream.stream());
  }

  Status start() override {
    if (running_) return {};
    if (requests_.empty())
      return std::unexpected(internal_error(describe() + ": start before configure"));
    if (vanished_) return std::unexpected(io_error(label(), "the camera is gone (unplugged?)"));
    camera_->requestCompleted.connect(this, &LibcameraCamera::completed);
    lc::ControlList controls(lc::controls::controls);
    set_manual_controls(controls);
    if (const int result = camera_->start(&controls); result < 0) {
      camera_->requestCompleted.disconnect(this);
      return std::unexpected(io_error(label(), std::string("start: ") + std::strerror(-result)));
    }
    running_ = true;
    for (auto& request : requests_) {
      request->reuse(lc::Request::ReuseBuffers);
      set_manual_controls(request->controls());
      if (const int result = camera_->queueRequest(request.get()); result < 0) {
        (void)stop();
        return std::unexpected(
            io_error(label(), std::string("queue a request: ") + std::strerror(-result)));
      }
    }
    return {};
  }

  Result<Frame> grab(milliseconds timeout) override {
    if (!running_) return std::unexpected(internal_error(describe() + ": grab before start"));
    const auto deadline = steady_clock::now() + timeout;
    for (;;) {
      lc::Request* request = nullptr;
      {
        std::unique_lock lock(mutex_);
        if (!ready_.wait_until(lock, deadline, [&] { return !completed_.empty() || vanished_; }))
          return std::unexpected(io_error(
              label(),
              "no frame within " + std::to_string(timeout.count()) + " ms (camera.timeout_ms)"));
        if (vanished_) return std::unexpected(io_error(label(), "the camera is gone (unplugged?)"));
        request = completed_.front();
        completed_.pop_front();
      }
      auto frame = to_frame(*request);
      request->reuse(lc::Request::ReuseBuffers);
      set_manual_controls(request->controls());
      if (const int result = camera_->queueRequest(request); result < 0)
        return std::unexpected(
            io_error(label(), std::string("queue a request: ") + std::strerror(-result)));
      if (!frame) return std::unexpected(frame.error());
      if (*frame) return std::move(**frame);
      // else a dropped or damaged frame: wait for the next
    }
  }

  Status stop() override {
    if (!running_) return {};
    running_ = false;
    const int result = camera_->stop();  // completes every queued request as cancelled
    camera_->requestCompleted.disconnect(this);
    std::lock_guard lock(mutex_);
    completed_.clear();
    if (result < 0 && !vanished_)
      return std::unexpected(io_error(label(), std::string("stop: ") + std::strerror(-result)));
    return {};
  }

  std::string describe() const override {
    std::string text = "libcamera " + label();
    if (width_ > 0)
      text += ", " + std::to_string(width_) + "x" + std::to_string(height_) + " " +
              std::string(format_.name);
    return text;
  }

 private:
  std::string label() const { return camera_label(camera_); }

  Result<lc::PixelFormat> choose_format(const lc::StreamConfiguration& stream,
                                        const std::optional<V4l2PixelFormat>& wanted) const {
    const std::vector<lc::PixelFormat> offered = stream.formats().pixelformats();
    if (wanted) {
      for (const auto& format : offered)
        if (const auto equivalent = v4l2_equivalent(format);
            equivalent && equivalent->fourcc == wanted->fourcc)
          return format;
      // A setting this camera cannot meet: bad input (exit 2), as v4l2 says it.
      return std::unexpected(
          bad_input(label(), "camera.format",
                    "does not offer " + std::string(wanted->name) +
                        " (camera.format; `psrig devices` lists what it does)"));
    }
    // "auto": the best for photometry of what the camera offers.
    std::optional<lc::PixelFormat> best;
    int best_rank = -1;
    for (const auto& format : offered)
      if (const auto equivalent = v4l2_equivalent(format);
          equivalent && equivalent->photometric_rank > best_rank) {
        best = format;
        best_rank = equivalent->photometric_rank;
      }
    if (!best) return std::unexpected(io_error(label(), "offers no pixel format psrig converts"));
    return *best;
  }

  Status allocate(lc::Stream* stream) {
    stream_ = stream;
    allocator_ = std::make_unique<lc::FrameBufferAllocator>(camera_);
    if (const int result = allocator_->allocate(stream); result < 0)
      return std::unexpected(
          io_error(label(), std::string("allocate buffers: ") + std::strerror(-result)));
    for (const auto& buffer : allocator_->buffers(stream)) {
      const lc::FrameBuffer::Plane& plane = buffer->planes().front();
      MappedBuffer mapped;
      mapped.length = plane.offset + plane.length;
      mapped.base = mmap(nullptr, mapped.length, PROT_READ, MAP_SHARED, plane.fd.get(), 0);
      if (mapped.base == MAP_FAILED)
        return std::unexpected(
            io_error(label(), std::string("map a buffer: ") + std::strerror(errno)));
      mapped.plane = {static_cast<const std::uint8_t*>(mapped.base) + plane.offset, plane.length};
      mapped_[buffer.get()] = mapped;
      std::unique_ptr<lc::Request> request = camera_->createRequest();
      if (!request || request->addBuffer(stream, buffer.get()) < 0)
        return std::unexpected(io_error(label(), "could not make a capture request"));
      requests_.push_back(std::move(request));
    }
    return {};
  }

  void release_buffers() {
    requests_.clear();
    for (auto& [buffer, mapped] : mapped_)
      munmap(mapped.base, mapped.length);
    mapped_.clear();
    if (allocator_ && stream_) allocator_->free(stream_);
    allocator_.reset();
    stream_ = nullptr;
  }

  void set_manual_controls(lc::ControlList& controls) const {
#if PSRIG_LIBCAMERA_AT_LEAST(0, 5)
    controls.set(lc::controls::ExposureTimeMode, lc::controls::ExposureTimeModeManual);
    controls.set(lc::controls::AnalogueGainMode, lc::controls::AnalogueGainModeManual);
#else
    controls.set(lc::controls::AeEnable, false);
#endif
    controls.set(lc::controls::ExposureTime, static_cast<std::int32_t>(settings_.exposure_us));
    controls.set(lc::controls::AnalogueGain, static_cast<float>(settings_.gain));
  }

  // Called on libcamera's thread.
  void completed(lc::Request* request) {
    if (request->status() == lc::Request::RequestCancelled) return;
    {
      std::lock_guard lock(mutex_);
      completed_.push_back(request);
    }
    ready_.notify_one();
  }

  void disconnected() {
    {
      std::lock_guard lock(mutex_);
      vanished_ = true;
    }
    ready_.notify_all();
  }

  // The request's frame; nothing for a frame the pipeline marked failed.
  Result<std::optional<Frame>> to_frame(lc::Request& request) const {
    const lc::FrameBuffer* buffer = request.buffers().begin()->second;
    const lc::FrameMetadata& meta = buffer->metadata();
    if (meta.status != lc::FrameMetadata::FrameSuccess) return std::nullopt;
    const MappedBuffer& mapped = mapped_.at(buffer);
    auto image = convert_v4l2_frame(
        mapped.plane.first(std::min<std::size_t>(mapped.plane.size(), meta.planes()[0].bytesused)),
        format_, width_, height_, stride_);
    if (!image) return std::unexpected(image.error());

    Frame frame;
    frame.image = std::move(*image);
    frame.sequence = meta.sequence;
    frame.exposure_us =
        request.metadata().get(lc::controls::ExposureTime).value_or(settings_.exposure_us);
    frame.gain = request.metadata()
                     .get(lc::controls::AnalogueGain)
                     .value_or(static_cast<float>(settings_.gain));
    // The stamp marks the first row's exposure, or on some pipelines the
    // start of its readout: assuming the latter dates a frame earlier, so a
    // frame that saw the old lighting is never taken for a fresh one.
    const auto stamp = on_steady_clock(request.metadata()
                                           .get(lc::controls::SensorTimestamp)
                                           .value_or(static_cast<std::int64_t>(meta.timestamp)));
    frame.exposure_start = stamp - microseconds(frame.exposure_us);
    frame.exposure_end = stamp + microseconds(frame.exposure_us);
    frame.white_level = format_.white_level();
    // Black levels come scaled to 16 bits.
    if (const auto levels = request.metadata().get(lc::controls::SensorBlackLevels))
      frame.black_level = (*levels)[0] * (frame.white_level + 1) / 65536.0;
    frame.encoding = format_.linear ? formats::Encoding::linear : formats::Encoding::srgb;
    return std::optional<Frame>(std::move(frame));
  }

  std::shared_ptr<lc::CameraManager> manager_;  // first: outlives the camera
  std::shared_ptr<lc::Camera> camera_;
  config::CameraConfig settings_;
  std::unique_ptr<lc::CameraConfiguration> configuration_;
  std::unique_ptr<lc::FrameBufferAllocator> allocator_;
  lc::Stream* stream_ = nullptr;
  std::vector<std::unique_ptr<lc::Request>> requests_;
  std::map<const lc::FrameBuffer*, MappedBuffer> mapped_;
  V4l2PixelFormat format_;
  int width_ = 0, height_ = 0;
  std::size_t stride_ = 0;
  bool running_ = false;

  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<lc::Request*> completed_;
  bool vanished_ = false;
};

}  // namespace

// libcamera names formats as DRM does; the conversions go by V4L2's names.
std::optional<V4l2PixelFormat> v4l2_format_for_libcamera(std::string name) {
  if (name.ends_with("_CSI2P"))
    name = name.substr(0, name.size() - 6) + "P";  // SRGGB10_CSI2P: MIPI packed
  // DRM names colour formats by a little-endian word, V4L2 by bytes in memory.
  static const std::map<std::string, std::string> renamed = {
      {"R8", "GREY"},   {"R10", "Y10"},      {"R12", "Y12"},     {"R16", "Y16"},
      {"R10P", "Y10P"}, {"RGB888", "BGR24"}, {"BGR888", "RGB24"}};
  if (const auto it = renamed.find(name); it != renamed.end()) name = it->second;
  return find_v4l2_format(name);
}

Result<std::unique_ptr<Camera>> open_libcamera_camera(const config::CameraConfig& config) {
  auto manager = camera_manager();
  if (!manager) return std::unexpected(manager.error());
  const auto cameras = (*manager)->cameras();
  if (cameras.empty())
    return std::unexpected(io_error("libcamera",
                                    "no camera found (camera.backend = \"libcamera\"); "
                                    "`psrig devices` lists what is connected"));
  // camera.device defaults to the V4L2 node, which means "the first" here.
  std::shared_ptr<lc::Camera> camera = config.device.empty() || config.device == "/dev/video0"
                                           ? cameras.front()
                                           : (*manager)->get(config.device);
  if (!camera) {
    std::string known;
    for (const auto& c : cameras)
      known += (known.empty() ? "" : ", ") + c->id();
    return std::unexpected(bad_input(config.device, "camera.device",
                                     "no libcamera camera with this id; found: " + known));
  }
  if (camera->acquire() < 0)
    return std::unexpected(io_error(camera_label(camera), "is in use by another program"));
  return std::make_unique<LibcameraCamera>(std::move(*manager), std::move(camera));
}

Result<std::vector<std::string>> list_libcamera_cameras() {
  auto manager = camera_manager();
  if (!manager) return std::unexpected(manager.error());
  std::vector<std::string> found;
  for (const auto& camera : (*manager)->cameras())
    found.push_back(camera_label(camera));
  return found;
}

}  // namespace psrig::cameras
