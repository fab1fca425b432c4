#pragma once
// Where the kiosk's frames go: the KMS display, or (headless, for tests)
// an offscreen target whose frames are written as numbered PNGs.

#include <filesystem>
#include <memory>
#include <string>

#include "command.h"

namespace psrig::preview::cli {

struct KmsArgs {
  std::string device;     // "": the first DRM card with a connected display
  std::string connector;  // "": the first connected one
  std::string mode;       // "": the display's preferred mode
};
void add_kms_options(CLI::App& app, KmsArgs& args);

class KioskOutput {
 public:
  virtual ~KioskOutput() = default;
  [[nodiscard]] virtual std::string describe() const = 0;
  [[nodiscard]] virtual cv::Size size() const = 0;
  // Renderer defaults for this output's context and colour encoding.
  [[nodiscard]] virtual RendererOptions renderer_options() const = 0;
  virtual void begin_frame() = 0;                          // binds the framebuffer to draw into
  [[nodiscard]] virtual Status end_frame(long frame) = 0;  // shows (or writes) it
};

[[nodiscard]] Result<std::unique_ptr<KioskOutput>> open_headless_output(
    const std::string& size, int samples, const std::filesystem::path& out_dir);
[[nodiscard]] Result<std::unique_ptr<KioskOutput>> open_kms_output(const KmsArgs& args,
                                                                   int samples);

}  // namespace psrig::preview::cli
