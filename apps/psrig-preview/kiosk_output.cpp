#include "kiosk_output.h"

#include <cstdio>

#include "psrig/formats/image_io.h"

namespace psrig::preview::cli {
namespace {

class HeadlessOutput final : public KioskOutput {
 public:
  HeadlessOutput(HeadlessCanvas canvas, std::filesystem::path out_dir)
      : canvas_(std::move(canvas)), out_dir_(std::move(out_dir)) {}

  std::string describe() const override {
    return "headless " + std::to_string(size().width) + "x" + std::to_string(size().height) +
           " into " + out_dir_.string() + ", " + canvas_.context->describe();
  }
  cv::Size size() const override { return canvas_.target->size(); }
  RendererOptions renderer_options() const override {
    return cli::renderer_options(*canvas_.context);
  }
  void begin_frame() override { canvas_.target->bind(); }
  Status end_frame(long frame) override {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%06ld.png", frame);
    return formats::write_image(out_dir_ / name, canvas_.target->read());
  }

 private:
  HeadlessCanvas canvas_;
  std::filesystem::path out_dir_;
};

}  // namespace

void add_kms_options(CLI::App& app, KmsArgs& args) {
  app.add_option("--device", args.device, "DRM device (default: the first with a display)");
  app.add_option("--connector", args.connector, "Display connector, e.g. HDMI-A-1");
  app.add_option("--mode", args.mode, "Display mode WxH or WxH@HZ (default: preferred)");
}

Result<std::unique_ptr<KioskOutput>> open_headless_output(const std::string& size, int samples,
                                                          const std::filesystem::path& out_dir) {
  auto parsed = parse_size(size, "--size");
  if (!parsed) return std::unexpected(parsed.error());
  std::error_code error;
  std::filesystem::create_directories(out_dir, error);
  if (error) return std::unexpected(io_error(out_dir, "cannot create: " + error.message()));
  auto canvas = open_headless_canvas(*parsed, samples);
  if (!canvas) return std::unexpected(canvas.error());
  return std::make_unique<HeadlessOutput>(std::move(*canvas), out_dir);
}

}  // namespace psrig::preview::cli
