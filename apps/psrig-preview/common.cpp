#include <GLES3/gl3.h>
#include <string>

#include "command.h"
#include "psrig/base/width_height.h"
#include "psrig/formats/maps_reader.h"
#include "psrig/formats/scan_layout.h"

namespace psrig::preview::cli {

void add_view_options(CLI::App& app, ViewArgs& args) {
  app.add_option("--view", args.view,
                 "flat: the swatch head-on as scanned; patch: a draped sheet in perspective")
      ->check(CLI::IsMember({"flat", "patch"}))
      ->capture_default_str();
  app.add_option("--light", args.light, "Light kind")
      ->check(CLI::IsMember({"directional", "point"}))
      ->capture_default_str();
  app.add_option("--light-tilt", args.light_tilt,
                 "Light tilt in degrees, in the swatch plane from +x (right) toward +y (up)")
      ->capture_default_str();
  app.add_option("--light-slant", args.light_slant, "Light slant in degrees from the swatch normal")
      ->check(CLI::Range(0.0, 90.0))
      ->capture_default_str();
  app.add_option("--yaw", args.yaw, "Model yaw in degrees (about the vertical)")
      ->capture_default_str();
  app.add_option("--pitch", args.pitch, "Model pitch in degrees (about the horizontal)")
      ->capture_default_str();
  app.add_flag("--no-light-sphere", args.no_light_sphere, "Do not draw the light as a sphere");
}

void add_samples_option(CLI::App& app, int& samples) {
  app.add_option("--samples", samples, "Multisampling (0: off)")
      ->check(CLI::Range(0, 16))
      ->capture_default_str();
}

void add_lod_option(CLI::App& app, std::string& lod) {
  app.add_option("--lod", lod,
                 "Yarns' level of detail: auto (from their width in pixels), or near or far "
                 "forced")
      ->check(CLI::IsMember({"auto", "near", "far"}))
      ->capture_default_str();
}

YarnLevel yarn_level(const std::string& lod) {
  return lod == "near" ? YarnLevel::near : lod == "far" ? YarnLevel::far : YarnLevel::automatic;
}

SceneView scene_view(const ViewArgs& args) {
  SceneView view;
  view.kind = args.view == "flat" ? ViewKind::flat : ViewKind::patch;
  view.light.kind = args.light == "point" ? LightKind::point : LightKind::directional;
  view.light.tilt_deg = args.light_tilt;
  view.light.slant_deg = args.light_slant;
  view.model_yaw_deg = args.yaw;
  view.model_pitch_deg = args.pitch;
  view.show_light = !args.no_light_sphere;
  if (view.kind == ViewKind::patch) {  // a three-quarter view from above
    view.camera_yaw_deg = 15;
    view.camera_pitch_deg = 30;
  }
  return view;
}

Error with_scan_directory_hint(Error error, const std::filesystem::path& directory) {
  namespace fs = std::filesystem;
  if (!fs::is_regular_file(directory / formats::scan_files::kDescription)) return error;
  const fs::path scan_maps = directory / formats::scan_files::kMapsDirectory;
  if (fs::is_directory(scan_maps))
    error.message += "; " + directory.string() + " is a scan directory: did you mean " +
                     scan_maps.string() + "?";
  else
    error.message += "; " + directory.string() +
                     " is a scan directory not yet processed: run `psrig process " +
                     directory.string() + "` first";
  return error;
}

Result<SwatchMaps> load_maps_argument(const std::filesystem::path& directory) {
  auto maps = load_swatch_maps(directory);
  if (maps) return maps;
  return std::unexpected(with_scan_directory_hint(std::move(maps.error()), directory));
}

Result<ScanCloth> read_scan_cloth_argument(const std::filesystem::path& directory) {
  std::vector<std::string> warnings;
  auto maps = formats::read_maps(directory, warnings);
  if (!maps) return std::unexpected(with_scan_directory_hint(std::move(maps.error()), directory));
  return scan_cloth_of(*maps, std::move(warnings));
}

Result<cv::Size> parse_size(const std::string& text, const std::string& option) {
  if (const auto size = parse_width_height(text); size && size->width > 0 && size->height > 0)
    return cv::Size(size->width, size->height);
  return std::unexpected(bad_input("", option, "\"" + text + "\" is not a size like 1920x1080"));
}

Result<HeadlessCanvas> open_headless_canvas(cv::Size size, int samples) {
  auto context = EglContext::open_surfaceless();
  if (!context) return std::unexpected(context.error());
  auto target = OffscreenTarget::create(size, samples, ColourStorage::srgb);
  if (!target) return std::unexpected(target.error());
  return HeadlessCanvas{std::move(*context), std::move(*target)};
}

RendererOptions renderer_options(bool offers_anisotropy) {
  RendererOptions options;
  if (offers_anisotropy) {
    constexpr GLenum kMaxTextureMaxAnisotropy = 0x84FF;
    GLfloat most = 1;
    glGetFloatv(kMaxTextureMaxAnisotropy, &most);
    options.max_anisotropy = std::min(most, 8.0f);
  }
  return options;
}

}  // namespace psrig::preview::cli
