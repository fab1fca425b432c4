// The kiosk on a real display: DRM/KMS through KmsDisplay.

#include <GLES3/gl3.h>

#include "kiosk_output.h"
#include "psrig/preview/kms_display.h"

namespace psrig::preview::cli {
namespace {

class KmsOutput final : public KioskOutput {
 public:
  explicit KmsOutput(std::unique_ptr<KmsDisplay> display) : display_(std::move(display)) {}

  std::string describe() const override { return display_->describe(); }
  cv::Size size() const override { return display_->size(); }
  RendererOptions renderer_options() const override {
    RendererOptions options =
        cli::renderer_options(display_->has_extension("GL_EXT_texture_filter_anisotropic"));
    options.encode_srgb = !display_->srgb_surface();  // else the surface encodes
    return options;
  }
  void begin_frame() override { glBindFramebuffer(GL_FRAMEBUFFER, 0); }
  Status end_frame(long) override { return display_->present(); }

 private:
  std::unique_ptr<KmsDisplay> display_;
};

}  // namespace

Result<std::unique_ptr<KioskOutput>> open_kms_output(const KmsArgs& args, int samples) {
  auto display = KmsDisplay::open({args.device, args.connector, args.mode, samples});
  if (!display) return std::unexpected(display.error());
  return std::make_unique<KmsOutput>(std::move(*display));
}

}  // namespace psrig::preview::cli
