#include "psrig/preview/kms_display.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl3.h>
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <drm_fourcc.h>
#include <fcntl.h>
#include <filesystem>
#include <gbm.h>
#include <memory>
#include <poll.h>
#include <system_error>
#include <unistd.h>
#include <vector>
#include <xf86drm.h>
#include <xf86drmMode.h>

#include "gl_context_facts.h"
#include "psrig/preview/extension_list.h"

namespace psrig::preview {
namespace {

constexpr int kFlipTimeoutMs = 1000;
constexpr const char* kDriDirectory = "/dev/dri";

// libdrm's objects, each freed by its own function.
template <auto Free>
struct DrmFree {
  template <class T>
  void operator()(T* object) const {
    Free(object);
  }
};
using DrmResources = std::unique_ptr<drmModeRes, DrmFree<drmModeFreeResources>>;
using DrmConnector = std::unique_ptr<drmModeConnector, DrmFree<drmModeFreeConnector>>;
using DrmEncoder = std::unique_ptr<drmModeEncoder, DrmFree<drmModeFreeEncoder>>;
using DrmVersion = std::unique_ptr<drmVersion, DrmFree<drmFreeVersion>>;

// libdrm's mode calls return -errno.
std::string drm_error(int ret) {
  return std::strerror(ret < 0 ? -ret : errno);
}

// The mode's refresh as the kernel computes it, in Hz.
double refresh_hz(const drmModeModeInfo& mode) {
  if (mode.htotal == 0 || mode.vtotal == 0) return mode.vrefresh;
  double hz = mode.clock * 1000.0 / (static_cast<double>(mode.htotal) * mode.vtotal);
  if (mode.flags & DRM_MODE_FLAG_INTERLACE) hz *= 2;
  if (mode.flags & DRM_MODE_FLAG_DBLSCAN) hz /= 2;
  if (mode.vscan > 1) hz /= mode.vscan;
  return hz;
}

std::string connector_name(const drmModeConnector& connector) {
  const char* type = drmModeGetConnectorTypeName(connector.connector_type);
  return std::string(type ? type : "Unknown") + "-" + std::to_string(connector.connector_type_id);
}

// card0, card1, ..., card10 in numeric order.
std::vector<std::string> card_nodes() {
  std::vector<std::pair<long, std::string>> cards;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(kDriDirectory, error)) {
    const std::string name = entry.path().filename().string();
    if (!name.starts_with("card")) continue;
    char* end = nullptr;
    const long number = std::strtol(name.c_str() + 4, &end, 10);
    cards.emplace_back(end != nullptr && *end == '\0' ? number : 1L << 30, entry.path().string());
  }
  std::ranges::sort(cards);
  std::vector<std::string> paths;
  for (auto& card : cards)
    paths.push_back(std::move(card.second));
  return paths;
}

// The framebuffer of a GBM buffer, made once and removed with the buffer.
struct BoFramebuffer {
  int fd;
  uint32_t id;
};

void destroy_bo_framebuffer(gbm_bo* /*bo*/, void* data) {
  auto* framebuffer = static_cast<BoFramebuffer*>(data);
  drmModeRmFB(framebuffer->fd, framebuffer->id);
  delete framebuffer;
}

void on_page_flip(int /*fd*/, unsigned /*frame*/, unsigned /*sec*/, unsigned /*usec*/, void* data) {
  *static_cast<bool*>(data) = true;
}

}  // namespace

struct KmsDisplay::Impl {
  std::string device, connector;
  int fd = -1;
  uint32_t connector_id = 0, crtc_id = 0;
  drmModeModeInfo mode{};
  DisplayMode mode_info;
  drmModeCrtc* saved_crtc = nullptr;  // as found, given back at exit

  gbm_device* gbm = nullptr;
  gbm_surface* surface = nullptr;
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  EGLSurface window = EGL_NO_SURFACE;
  bool srgb = false;
  std::string description, extensions;  // the GL context's

  bool mode_set = false;      // the first present() sets the CRTC, later ones flip
  gbm_bo* shown = nullptr;    // scanned out now
  gbm_bo* pending = nullptr;  // flipped to, not yet scanned out
  bool flip_done = false;

  Impl() = default;
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
  ~Impl();

  [[nodiscard]] Error failure(const std::string& message) const {
    return io_error(device, connector.empty() ? message : connector + ": " + message);
  }
  Status probe(const Options& options);
  Status start_egl(int samples);
  Result<uint32_t> framebuffer_for(gbm_bo* bo) const;
  Status wait_for_flip();
};

// Opens the device and picks connector, mode and CRTC, touching nothing.
Status KmsDisplay::Impl::probe(const Options& options) {
  fd = ::open(device.c_str(), O_RDWR | O_CLOEXEC);
  if (fd < 0) {
    const int error = errno;
    std::string message = std::string("cannot open the DRM device: ") + std::strerror(error);
    if (error == EACCES || error == EPERM)
      message += " (is the user in the video or render group?)";
    return std::unexpected(io_error(device, message));
  }
  const DrmVersion driver(drmGetVersion(fd));
  if (!driver)
    return std::unexpected(
        io_error(device, std::string("not a DRM device (") + std::strerror(errno) +
                             "); the kiosk needs a display card such as /dev/dri/card0"));
  const DrmResources resources(drmModeGetResources(fd));
  if (!resources)
    return std::unexpected(
        io_error(device,
                 "a DRM device without modesetting (a render node?); the kiosk needs a display "
                 "card such as /dev/dri/card0"));

  std::vector<DrmConnector> drm_connectors;
  std::vector<ConnectorInfo> infos;
  for (int i = 0; i < resources->count_connectors; ++i) {
    DrmConnector found(drmModeGetConnector(fd, resources->connectors[i]));
    if (!found) continue;
    ConnectorInfo info{
        found->connector_id, connector_name(*found), found->connection == DRM_MODE_CONNECTED, {}};
    for (int m = 0; m < found->count_modes; ++m) {
      const drmModeModeInfo& raw = found->modes[m];
      info.modes.push_back({raw.hdisplay, raw.vdisplay, refresh_hz(raw),
                            (raw.type & DRM_MODE_TYPE_PREFERRED) != 0, raw.name});
    }
    infos.push_back(std::move(info));
    drm_connectors.push_back(std::move(found));
  }
  auto choice = choose_display_mode(infos, options.connector, options.mode);
  if (!choice) {
    Error error = choice.error();
    error.file = device;
    return std::unexpected(error);
  }
  const drmModeConnector& chosen = *drm_connectors[choice->connector];
  connector = infos[choice->connector].name;
  connector_id = chosen.connector_id;
  mode = chosen.modes[choice->mode];
  mode_info = infos[choice->connector].modes[choice->mode];

  // The encoder's CRTC when it already drives one, else any it can use.
  if (chosen.encoder_id != 0)
    if (const DrmEncoder encoder(drmModeGetEncoder(fd, chosen.encoder_id)); encoder)
      crtc_id = encoder->crtc_id;
  for (int e = 0; e < chosen.count_encoders && crtc_id == 0; ++e) {
    const DrmEncoder encoder(drmModeGetEncoder(fd, chosen.encoders[e]));
    if (!encoder) continue;
    for (int c = 0; c < resources->count_crtcs && crtc_id == 0; ++c)
      if (encoder->possible_crtcs & (1u << c)) crtc_id = resources->crtcs[c];
  }
  if (crtc_id == 0) return std::unexpected(failure("no CRTC can drive this connector"));
  saved_crtc = drmModeGetCrtc(fd, crtc_id);

  // Said here rather than as EACCES at the first frame.
  if (!drmIsMaster(fd))
    return std::unexpected(
        failure("not the DRM master: another display server or compositor (X, Wayland, a desktop "
                "session) drives this device; stop it or run the kiosk on a free VT"));
  return {};
}

Status KmsDisplay::Impl::start_egl(int samples) {
  gbm = gbm_create_device(fd);
  if (gbm == nullptr)
    return std::unexpected(
        failure("gbm_create_device failed; is Mesa's GBM for this driver installed (libgbm1, "
                "libgl1-mesa-dri)?"));
  const auto width = static_cast<uint32_t>(mode.hdisplay);
  const auto height = static_cast<uint32_t>(mode.vdisplay);
  surface = gbm_surface_create(gbm, width, height, GBM_FORMAT_XRGB8888,
                               GBM_BO_USE_SCANOUT | GBM_BO_USE_RENDERING);
  if (surface == nullptr)
    return std::unexpected(failure("gbm_surface_create(" + describe_mode(mode_info) +
                                   ", XRGB8888, scanout) failed: " + std::strerror(errno)));

  const std::string_view client_extensions = egl_extension_list(EGL_NO_DISPLAY);
  if (!extension_listed(client_extensions, "EGL_KHR_platform_gbm") &&
      !extension_listed(client_extensions, "EGL_MESA_platform_gbm"))
    return std::unexpected(
        failure("EGL offers no GBM platform (EGL_KHR_platform_gbm); the kiosk needs Mesa's EGL "
                "(libegl-mesa0)"));
  display = eglGetPlatformDisplay(EGL_PLATFORM_GBM_KHR, gbm, nullptr);
  if (display == EGL_NO_DISPLAY)
    return std::unexpected(failure(egl_error("eglGetPlatformDisplay(GBM)")));
  if (eglInitialize(display, nullptr, nullptr) != EGL_TRUE) {
    display = EGL_NO_DISPLAY;  // nothing to terminate
    return std::unexpected(failure(egl_error("eglInitialize(GBM)")));
  }
  if (eglBindAPI(EGL_OPENGL_ES_API) != EGL_TRUE)
    return std::unexpected(failure(egl_error("eglBindAPI(GLES)")));

  // Scanout reads XRGB8888: the config's native visual must be that format.
  // Multisampling as asked, else the most that is offered below it.
  EGLConfig config = nullptr;
  for (int tried = std::max(samples, 0); config == nullptr; tried /= 2) {
    const EGLint attributes[] = {EGL_SURFACE_TYPE,
                                 EGL_WINDOW_BIT,
                                 EGL_RED_SIZE,
                                 8,
                                 EGL_GREEN_SIZE,
                                 8,
                                 EGL_BLUE_SIZE,
                                 8,
                                 EGL_DEPTH_SIZE,
                                 24,
                                 EGL_RENDERABLE_TYPE,
                                 EGL_OPENGL_ES3_BIT,
                                 EGL_SAMPLE_BUFFERS,
                                 tried > 0 ? 1 : 0,
                                 EGL_SAMPLES,
                                 tried,
                                 EGL_NONE};
    EGLint count = 0;
    if (eglChooseConfig(display, attributes, nullptr, 0, &count) == EGL_TRUE && count > 0) {
      std::vector<EGLConfig> configs(static_cast<std::size_t>(count));
      eglChooseConfig(display, attributes, configs.data(), count, &count);
      for (EGLint i = 0; i < count && config == nullptr; ++i) {
        EGLint visual = 0;
        if (eglGetConfigAttrib(display, configs[static_cast<std::size_t>(i)], EGL_NATIVE_VISUAL_ID,
                               &visual) == EGL_TRUE &&
            static_cast<uint32_t>(visual) == GBM_FORMAT_XRGB8888)
          config = configs[static_cast<std::size_t>(i)];
      }
    }
    if (tried == 0) break;
  }
  if (config == nullptr)
    return std::unexpected(
        failure("EGL offers no GLES 3 window config for XRGB8888 with a 24-bit depth buffer"));

  // An sRGB surface encodes on write, so the shaders can stay linear.
  bool asked_srgb = false;
  if (extension_listed(egl_extension_list(display), "EGL_KHR_gl_colorspace")) {
    const EGLAttrib srgb_attributes[] = {EGL_GL_COLORSPACE_KHR, EGL_GL_COLORSPACE_SRGB_KHR,
                                         EGL_NONE};
    window = eglCreatePlatformWindowSurface(display, config, surface, srgb_attributes);
    asked_srgb = window != EGL_NO_SURFACE;
  }
  if (window == EGL_NO_SURFACE)  // no sRGB, or the driver refused it for this config
    window = eglCreatePlatformWindowSurface(display, config, surface, nullptr);
  if (window == EGL_NO_SURFACE)
    return std::unexpected(failure(egl_error("eglCreatePlatformWindowSurface(GBM)")));

  const EGLint context_attributes[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 0,
                                       EGL_NONE};
  context = eglCreateContext(display, config, EGL_NO_CONTEXT, context_attributes);
  if (context == EGL_NO_CONTEXT)
    return std::unexpected(failure(egl_error("eglCreateContext(GLES 3.0)")));
  if (eglMakeCurrent(display, window, window, context) != EGL_TRUE)
    return std::unexpected(failure(egl_error("eglMakeCurrent(GBM window)")));

  GLint major = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  if (major < 3)
    return std::unexpected(
        failure("the context is GLES " + std::to_string(major) + "; the preview needs GLES 3.0"));
  description = gl_description();
  extensions = gl_extension_list();
  // Asked is not granted: the framebuffer says what encoding it really has.
  if (asked_srgb) {
    GLint encoding = GL_LINEAR;
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glGetFramebufferAttachmentParameteriv(GL_FRAMEBUFFER, GL_BACK,
                                          GL_FRAMEBUFFER_ATTACHMENT_COLOR_ENCODING, &encoding);
    srgb = encoding == GL_SRGB;
  }
  return {};
}

Result<uint32_t> KmsDisplay::Impl::framebuffer_for(gbm_bo* bo) const {
  if (const auto* made = static_cast<BoFramebuffer*>(gbm_bo_get_user_data(bo))) return made->id;
  uint32_t handles[4] = {}, strides[4] = {}, offsets[4] = {};
  uint64_t modifiers[4] = {};
  const uint64_t modifier = gbm_bo_get_modifier(bo);
  const int planes = std::min(gbm_bo_get_plane_count(bo), 4);
  for (int p = 0; p < planes; ++p) {
    handles[p] = gbm_bo_get_handle_for_plane(bo, p).u32;
    strides[p] = gbm_bo_get_stride_for_plane(bo, p);
    offsets[p] = gbm_bo_get_offset(bo, p);
    modifiers[p] = modifier;
  }
  const uint32_t width = gbm_bo_get_width(bo), height = gbm_bo_get_height(bo);
  const uint32_t format = gbm_bo_get_format(bo);
  uint32_t id = 0;
  int ret = -EINVAL;
  if (modifier != DRM_FORMAT_MOD_INVALID)
    ret = drmModeAddFB2WithModifiers(fd, width, height, format, handles, strides, offsets,
                                     modifiers, &id, DRM_MODE_FB_MODIFIERS);
  if (ret != 0)  // drivers without modifier support take the plain call
    ret = drmModeAddFB2(fd, width, height, format, handles, strides, offsets, &id, 0);
  if (ret != 0)
    return std::unexpected(
        failure("cannot make a framebuffer of a GBM buffer (drmModeAddFB2): " + drm_error(ret)));
  gbm_bo_set_user_data(bo, new BoFramebuffer{fd, id}, destroy_bo_framebuffer);
  return id;
}

// Waits for the pending flip's event, then gives the buffer it replaced back
// to GBM for drawing.
Status KmsDisplay::Impl::wait_for_flip() {
  drmEventContext events{};
  events.version = 2;
  events.page_flip_handler = on_page_flip;
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::milliseconds(kFlipTimeoutMs);
  while (!flip_done) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                          deadline - std::chrono::steady_clock::now())
                          .count();
    if (left <= 0)
      return std::unexpected(failure("the page flip did not complete within " +
                                     std::to_string(kFlipTimeoutMs) +
                                     " ms (display switched off or driver stuck?)"));
    pollfd poll_fd{fd, POLLIN, 0};
    const int ready = ::poll(&poll_fd, 1, static_cast<int>(left));
    if (ready < 0) {
      if (errno == EINTR) continue;
      return std::unexpected(
          failure(std::string("poll on the DRM device failed: ") + std::strerror(errno)));
    }
    if (ready == 0) continue;
    if (poll_fd.revents & (POLLERR | POLLHUP | POLLNVAL))
      return std::unexpected(failure("the DRM device went away while waiting for a page flip"));
    if (drmHandleEvent(fd, &events) != 0)
      return std::unexpected(
          failure(std::string("reading the DRM device's events failed: ") + std::strerror(errno)));
  }
  flip_done = false;
  if (shown != nullptr) gbm_surface_release_buffer(surface, shown);
  shown = pending;
  pending = nullptr;
  return {};
}

KmsDisplay::Impl::~Impl() {
  if (pending != nullptr) (void)wait_for_flip();
  if (mode_set && saved_crtc != nullptr) {
    // Back to what was shown before (the console), or off if it was off.
    if (saved_crtc->mode_valid && saved_crtc->buffer_id != 0)
      drmModeSetCrtc(fd, saved_crtc->crtc_id, saved_crtc->buffer_id, saved_crtc->x, saved_crtc->y,
                     &connector_id, 1, &saved_crtc->mode);
    else
      drmModeSetCrtc(fd, crtc_id, 0, 0, 0, nullptr, 0, nullptr);
  }
  // Locked buffers go back before the EGL surface that owns them is gone;
  // destroying it destroys them, and with them their framebuffers.
  if (surface != nullptr) {
    if (pending != nullptr) gbm_surface_release_buffer(surface, pending);
    if (shown != nullptr) gbm_surface_release_buffer(surface, shown);
  }
  if (display != EGL_NO_DISPLAY) {
    eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (window != EGL_NO_SURFACE) eglDestroySurface(display, window);
    if (context != EGL_NO_CONTEXT) eglDestroyContext(display, context);
    eglTerminate(display);
  }
  if (surface != nullptr) gbm_surface_destroy(surface);
  if (gbm != nullptr) gbm_device_destroy(gbm);
  if (saved_crtc != nullptr) drmModeFreeCrtc(saved_crtc);
  if (fd >= 0) ::close(fd);
}

KmsDisplay::KmsDisplay(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
KmsDisplay::~KmsDisplay() = default;

Result<std::unique_ptr<KmsDisplay>> KmsDisplay::open(const Options& options) {
  std::unique_ptr<Impl> impl;
  if (!options.device.empty()) {
    impl = std::make_unique<Impl>();
    impl->device = options.device;
    if (auto probed = impl->probe(options); !probed) return std::unexpected(probed.error());
  } else {
    // The first card that has the display asked for; each other's reason kept.
    const std::vector<std::string> cards = card_nodes();
    if (cards.empty())
      return std::unexpected(
          io_error(kDriDirectory,
                   "no DRM device found (no /dev/dri/card*): is the display's kernel "
                   "driver loaded, and /dev/dri passed into the container if in one?"));
    std::string reasons;
    bool all_bad_input = true;
    for (const auto& card : cards) {
      auto candidate = std::make_unique<Impl>();
      candidate->device = card;
      auto probed = candidate->probe(options);
      if (probed) {
        impl = std::move(candidate);
        break;
      }
      all_bad_input = all_bad_input && probed.error().kind == ErrorKind::bad_input;
      reasons += (reasons.empty() ? "" : "; ") + probed.error().describe();
    }
    if (!impl) {
      Error error =
          io_error(kDriDirectory, "no DRM device found with a usable display: " + reasons);
      if (all_bad_input) error.kind = ErrorKind::bad_input;
      return std::unexpected(error);
    }
  }
  if (auto started = impl->start_egl(options.samples); !started)
    return std::unexpected(started.error());
  return std::unique_ptr<KmsDisplay>(new KmsDisplay(std::move(impl)));
}

cv::Size KmsDisplay::size() const {
  return {impl_->mode.hdisplay, impl_->mode.vdisplay};
}

std::string KmsDisplay::describe() const {
  return impl_->device + " " + impl_->connector + " " + describe_mode(impl_->mode_info) + ", " +
         impl_->description;
}

bool KmsDisplay::srgb_surface() const {
  return impl_->srgb;
}

bool KmsDisplay::has_extension(std::string_view name) const {
  return extension_listed(impl_->extensions, name);
}

Status KmsDisplay::present() {
  Impl& d = *impl_;
  if (d.pending != nullptr)  // an earlier flip that timed out
    if (auto waited = d.wait_for_flip(); !waited) return waited;
  if (eglSwapBuffers(d.display, d.window) != EGL_TRUE)
    return std::unexpected(d.failure(egl_error("eglSwapBuffers")));
  gbm_bo* bo = gbm_surface_lock_front_buffer(d.surface);
  if (bo == nullptr)
    return std::unexpected(d.failure("gbm_surface_lock_front_buffer gave no buffer"));
  auto framebuffer = d.framebuffer_for(bo);
  if (!framebuffer) {
    gbm_surface_release_buffer(d.surface, bo);
    return std::unexpected(framebuffer.error());
  }
  const auto hint = [](int ret) {
    return ret == -EACCES || ret == -EPERM
               ? " (another process is DRM master: stop the display server or compositor)"
               : "";
  };
  if (!d.mode_set) {
    const int ret =
        drmModeSetCrtc(d.fd, d.crtc_id, *framebuffer, 0, 0, &d.connector_id, 1, &d.mode);
    if (ret != 0) {
      gbm_surface_release_buffer(d.surface, bo);
      return std::unexpected(d.failure("setting the mode " + describe_mode(d.mode_info) +
                                       " failed: " + drm_error(ret) + hint(ret)));
    }
    d.mode_set = true;
    d.shown = bo;
    return {};
  }
  const int ret =
      drmModePageFlip(d.fd, d.crtc_id, *framebuffer, DRM_MODE_PAGE_FLIP_EVENT, &d.flip_done);
  if (ret != 0) {
    gbm_surface_release_buffer(d.surface, bo);
    return std::unexpected(d.failure("page flip failed: " + drm_error(ret) + hint(ret)));
  }
  d.pending = bo;
  return d.wait_for_flip();
}

}  // namespace psrig::preview
