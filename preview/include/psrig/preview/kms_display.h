#pragma once
// The kiosk's display: a GLES 3 context drawing full screen through DRM/KMS,
// into GBM buffers shown by page flipping, with no X or Wayland. Needs DRM
// master (no other compositor on the VT) and the user in the video group.
// Current on the thread that opened it; EGL, GBM and DRM stay in the source.

#include <memory>
#include <string>
#include <string_view>

#include <opencv2/core.hpp>

#include "psrig/preview/display_mode.h"

namespace psrig::preview {

class KmsDisplay {
 public:
  struct Options {
    std::string device;     // "" = the first /dev/dri/card* with a connected connector
    std::string connector;  // "" = the first connected, else e.g. "HDMI-A-1"
    std::string mode;       // "" = the display's preferred, else "1920x1080[@60]"
    int samples = 0;        // MSAA on the window surface, fewer when not offered
  };

  // Lights nothing up yet: the first present() sets the mode.
  [[nodiscard]] static Result<std::unique_ptr<KmsDisplay>> open(const Options& options);
  // Waits for a flip in flight and gives the CRTC back as it was found.
  ~KmsDisplay();
  KmsDisplay(const KmsDisplay&) = delete;
  KmsDisplay& operator=(const KmsDisplay&) = delete;

  [[nodiscard]] cv::Size size() const;
  // "/dev/dri/card0 HDMI-A-1 1920x1080@60Hz, llvmpipe (...), OpenGL ES 3.2 Mesa 22.3.6"
  [[nodiscard]] std::string describe() const;
  // The window surface encodes sRGB itself: the renderer's shader writes
  // linear values and leaves encoding to it.
  [[nodiscard]] bool srgb_surface() const;
  // A GL extension the context offers: detected, never assumed.
  [[nodiscard]] bool has_extension(std::string_view name) const;

  // Shows the frame drawn into the default framebuffer; waits for the flip
  // (at the display's refresh). Errors name the device and connector.
  [[nodiscard]] Status present();

 private:
  struct Impl;
  explicit KmsDisplay(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace psrig::preview
