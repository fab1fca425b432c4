#include "psrig/export/u3m_export.h"

#include <chrono>
#include <ctime>
#include <random>
#include <regex>
#include <unistd.h>

#include <opencv2/imgproc.hpp>

#include "export_target.h"
#include "package_files.h"
#include "psrig/formats/atomic_directory.h"
#include "texture_set.h"
#include "u3ma_archive.h"

namespace psrig::export_ {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kPreviewMaxPx = 1024;

std::string now_utc() {
  const std::time_t t = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&t, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

// RFC 3339 date-time, as the schema's "format": "date-time" wants.
bool is_rfc3339(const std::string& s) {
  static const std::regex pattern(
      R"(^\d{4}-\d{2}-\d{2}T\d{2}:\d{2}:\d{2}(\.\d+)?(Z|[+-]\d{2}:\d{2})$)");
  return std::regex_match(s, pattern);
}

// A random (version 4, variant 1) UUID.
std::string uuid4() {
  std::random_device device;
  std::mt19937_64 random((static_cast<std::uint64_t>(device()) << 32) ^ device());
  std::uint64_t hi = random();
  std::uint64_t lo = random();
  hi = (hi & ~0xF000ULL) | 0x4000ULL;              // version 4
  lo = (lo & ~(0xC0ULL << 56)) | (0x80ULL << 56);  // variant 1 (10xx)
  char text[40];
  std::snprintf(text, sizeof text, "%08x-%04x-%04x-%04x-%012llx", static_cast<unsigned>(hi >> 32),
                static_cast<unsigned>((hi >> 16) & 0xFFFF), static_cast<unsigned>(hi & 0xFFFF),
                static_cast<unsigned>(lo >> 48),
                static_cast<unsigned long long>(lo & 0xFFFFFFFFFFFFULL));
  return text;
}

json number_param(double constant) {
  return {{"constant", constant}, {"texture", nullptr}};
}

// The image object: physical size in mm, DPI from the pixels over it.
json image_json(const std::string& path, cv::Size px, double width_mm, double height_mm) {
  return {{"path", path},
          {"width", width_mm},
          {"height", height_mm},
          {"dpi", {{"x", px.width * 25.4 / width_mm}, {"y", px.height * 25.4 / height_mm}}},
          {"repeat", {{"rotation", 0.0}, {"mode", "normal"}}}};
}

// The preview U3M asks for (a rendering that shows the material): the
// albedo lit by one light from the upper left through the normal map,
// Lambert's law plus a little ambient, at most 1024 px on a side.
cv::Mat render_preview(const TextureSet& t) {
  const double scale =
      std::min(1.0, static_cast<double>(kPreviewMaxPx) / std::max(t.albedo.cols, t.albedo.rows));
  const cv::Size size(std::max(1, static_cast<int>(std::lround(t.albedo.cols * scale))),
                      std::max(1, static_cast<int>(std::lround(t.albedo.rows * scale))));
  cv::Mat albedo;
  cv::Mat normal;
  cv::resize(t.albedo, albedo, size, 0, 0, cv::INTER_AREA);
  cv::resize(t.normal, normal, size, 0, 0, cv::INTER_AREA);
  const cv::Vec3d light = cv::normalize(cv::Vec3d(-0.5, 0.5, 1.0));  // x right, y up, z out
  cv::Mat out(size, CV_8UC3);
  out.forEach<cv::Vec3b>([&](cv::Vec3b& px, const int* pos) {
    const auto& n16 = normal.at<cv::Vec3w>(pos[0], pos[1]);  // BGR
    cv::Vec3d n(n16[2] / 32767.5 - 1, n16[1] / 32767.5 - 1, n16[0] / 32767.5 - 1);
    const double len = cv::norm(n);
    n = len > 0 ? n / len : cv::Vec3d(0, 0, 1);
    const double shade = 0.25 + 0.85 * std::max(0.0, n.dot(light));
    const auto& a = albedo.at<cv::Vec3b>(pos[0], pos[1]);
    for (int c = 0; c < 3; ++c) {
      const double s = a[c] / 255.0;
      double linear = s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4);
      linear = std::min(1.0, linear * shade);
      const double back =
          linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1 / 2.4) - 0.055;
      px[c] = cv::saturate_cast<std::uint8_t>(back * 255.0);
    }
  });
  return out;
}

}  // namespace

json u3m_document(const MaterialSource& source, double mean_height, double height_low,
                  double height_high, const cv::Vec3d& mean_linear_rgb, bool has_height,
                  cv::Size preview_px) {
  const double w = source.width_mm();
  const double h = source.height_mm();
  const cv::Size px(source.width_px, source.height_px);
  const json colour_constant = {{"r", std::clamp(mean_linear_rgb[0], 0.0, 1.0)},
                                {"g", std::clamp(mean_linear_rgb[1], 0.0, 1.0)},
                                {"b", std::clamp(mean_linear_rgb[2], 0.0, 1.0)}};
  json displacement = number_param(0.0);
  if (has_height) {
    // offset + grey * factor, grey in [0, 1]: millimetres (U3M's unit of length).
    displacement = {{"constant", mean_height},
                    {"texture",
                     {{"factor", height_high - height_low},
                      {"offset", height_low},
                      {"image", image_json(package_files::kHeight, px, w, h)}}}};
  }
  const json front = {
      {"shader", "principled"},
      {"alpha", number_param(1.0)},
      {"anisotropy_value", number_param(0.0)},
      {"anisotropy_rotation", number_param(0.0)},
      {"clearcoat_value", number_param(0.0)},
      {"clearcoat_normal",
       {{"constant", {{"x", 0.0}, {"y", 0.0}, {"z", 1.0}}}, {"texture", nullptr}}},
      {"clearcoat_roughness", number_param(0.0)},
      {"ior", number_param(1.4)},
      {"metalness", number_param(0.0)},
      {"normal",
       {{"constant", {{"x", 0.0}, {"y", 0.0}, {"z", 1.0}}},
        {"texture", {{"scale", 1.0}, {"image", image_json(package_files::kNormal, px, w, h)}}}}},
      {"displacement", displacement},
      {"roughness", number_param(0.8)},
      // Cloth: full sheen tinted toward the base colour, as the glTF export's
      // KHR_materials_sheen; a convention, not a measurement.
      {"sheen_value", number_param(1.0)},
      {"sheen_tint", number_param(1.0)},
      {"specular_value", number_param(0.5)},
      {"specular_tint", number_param(0.0)},
      {"subsurface_radius", number_param(0.0)},
      {"subsurface_value", number_param(0.0)},
      {"transmission", number_param(0.0)},
      {"basecolor",
       {{"constant", colour_constant},
        {"texture",
         {{"mode", "multiply"},
          {"factor", {{"r", 1.0}, {"g", 1.0}, {"b", 1.0}}},
          {"image", image_json(package_files::kAlbedo, px, w, h)}}}}},
      {"subsurface_color",
       {{"constant", {{"r", 1.0}, {"g", 1.0}, {"b", 1.0}}}, {"texture", nullptr}}},
      {"preview",
       {{"path", package_files::kPreview},
        {"width", w},
        {"height", h},
        {"dpi", {{"x", preview_px.width * 25.4 / w}, {"y", preview_px.height * 25.4 / h}}}}}};
  const std::string created = is_rfc3339(source.scan_time) ? source.scan_time : now_utc();
  std::string description = source.sample_description;
  if (!description.empty()) description += ". ";
  description += "Scanned by psrig (photometric stereo)";
  if (!source.pixel_size_mm)
    description += "; no pixel size was known: sizes are in pixels, 1 px written as 1 mm";
  return {{"schema", kU3mSchemaVersion},
          {"material",
           {{"id", uuid4()},
            {"name", source.sample_id.empty() ? std::string("psrig scan") : source.sample_id},
            {"description", description},
            {"created", created},
            {"modified", now_utc()},
            {"front", front},
            {"back", nullptr},
            {"side", nullptr},
            {"physics", nullptr},
            {"metadata", nullptr}}},
          {"custom",
           {{"psrig",
             {{"units", source.pixel_size_mm ? "mm" : "px"},
              {"pixel_size_mm", source.pixel_size_mm ? json(*source.pixel_size_mm) : json()},
              {"seamless_tile", source.tile},
              {"sample_id", source.sample_id.empty() ? json() : json(source.sample_id)},
              {"scan_time", source.scan_time.empty() ? json() : json(source.scan_time)}}}}}};
}

Result<ExportResult> export_u3m(const MaterialSource& source, const fs::path& out,
                                const U3mOptions& options) {
  std::error_code ec;
  const std::string stem = out.stem().string();
  const std::string main_file = stem + ".u3m";
  if (options.archive && fs::is_directory(out, ec))
    return std::unexpected(bad_input(out, "--out", "is a directory; name the .u3ma file"));
  std::optional<formats::AtomicDirectory::Existing> existing;
  if (!options.archive) {
    auto checked = check_directory_target(out, main_file);
    if (!checked) return std::unexpected(checked.error());
    existing = *checked;
  }
  const fs::path parent = out.has_parent_path() ? out.parent_path() : fs::path(".");
  if (!fs::is_directory(parent, ec))
    return std::unexpected(bad_input(out, "--out", "its directory does not exist; make it first"));

  auto textures = load_textures(source);
  if (!textures) return std::unexpected(textures.error());
  ExportResult result = export_result(source, out);

  std::vector<ArchiveEntry> files;  // textures, preview, then the document
  const auto add = [&](const std::string& name, const cv::Mat& image, TextureKind kind) -> Status {
    auto png = encode_png(image, texture_metadata(source, *textures, kind));
    if (!png) return std::unexpected(png.error());
    files.push_back({name, std::move(*png), false});
    return {};
  };
  if (auto ok = add(package_files::kAlbedo, textures->albedo, TextureKind::albedo); !ok)
    return std::unexpected(ok.error());
  if (auto ok = add(package_files::kNormal, textures->normal, TextureKind::normal); !ok)
    return std::unexpected(ok.error());
  const bool has_height = !textures->height.empty();
  if (has_height)
    if (auto ok = add(package_files::kHeight, textures->height, TextureKind::height); !ok)
      return std::unexpected(ok.error());
  if (options.directx_normal)
    if (auto ok =
            add(package_files::kNormalDirectx, to_directx(textures->normal), TextureKind::normal_directx);
        !ok)
      return std::unexpected(ok.error());
  const cv::Mat preview = render_preview(*textures);
  {
    // The preview's own pixel size: the material's over fewer pixels.
    formats::ImageMetadata m = texture_metadata(source, *textures, TextureKind::albedo);
    if (m.pixel_size_mm) *m.pixel_size_mm *= static_cast<double>(source.width_px) / preview.cols;
    auto png = encode_png(preview, m);
    if (!png) return std::unexpected(png.error());
    files.push_back({package_files::kPreview, std::move(*png), false});
  }
  const json document =
      u3m_document(source, textures->height_mean, textures->height_low, textures->height_high,
                   textures->mean_linear_rgb, has_height, preview.size());
  const std::string text = document.dump(4) + "\n";
  // Stored too: minizip marks a deflated text entry's internal attributes
  // "text", which the container forbids; the JSON is a few kB.
  files.push_back({main_file, std::vector<unsigned char>(text.begin(), text.end()), false});

  if (options.archive) {
    const fs::path staging =
        parent / ("." + out.filename().string() + ".partial-" + std::to_string(::getpid()));
    fs::remove(staging, ec);
    if (auto ok = write_u3ma(staging, files); !ok) {
      fs::remove(staging, ec);
      return std::unexpected(io_error(out, "cannot write: " + ok.error().message));
    }
    fs::rename(staging, out, ec);
    if (ec) {
      std::error_code ignored;
      fs::remove(staging, ignored);
      return std::unexpected(io_error(out, "cannot rename into place: " + ec.message()));
    }
    return result;
  }
  auto staging = formats::AtomicDirectory::create(out);
  if (!staging)
    return std::unexpected(
        io_error(out, "cannot make the export here: " + staging.error().message));
  for (const auto& file : files)
    if (auto ok = write_bytes(staging->path() / file.name, file.bytes); !ok)
      return std::unexpected(ok.error());
  if (auto ok = staging->commit(*existing, false); !ok) return std::unexpected(ok.error());
  return result;
}

}  // namespace psrig::export_
