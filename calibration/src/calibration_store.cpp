#include "psrig/calibration/calibration_store.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fcntl.h>
#include <fstream>
#include <sstream>
#include <system_error>
#include <unistd.h>

namespace psrig::calibration {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

double round_to(double value, double step) {
  return std::round(value / step) * step;
}

json vec(const cv::Vec3d& v) {
  return json::array({round_to(v[0], 1e-6), round_to(v[1], 1e-6), round_to(v[2], 1e-6)});
}

json circle_json(const Circle& c) {
  return {{"centre_px", {round_to(c.centre.x, 1e-3), round_to(c.centre.y, 1e-3)}},
          {"radius_px", round_to(c.radius, 1e-3)},
          {"fit_rms_px", round_to(c.rms_px, 1e-4)},
          {"edge_points", c.points}};
}

json estimate_json(const LightEstimate& e) {
  json j = {{"direction", vec(e.direction)},
            {"tilt_deg", round_to(tilt_deg(e.direction), 1e-3)},
            {"slant_deg", round_to(slant_deg(e.direction), 1e-3)},
            {"intensity", round_to(e.intensity, 1e-5)},
            {"uncertainty_deg", round_to(e.uncertainty_deg, 1e-4)},
            {"frames", e.frames}};
  if (e.highlight_px)
    j["highlight_px"] = {round_to(e.highlight_px->x, 1e-3), round_to(e.highlight_px->y, 1e-3)};
  if (e.highlight_spread_deg) j["highlight_spread_deg"] = round_to(*e.highlight_spread_deg, 1e-4);
  if (e.frames_spread_deg) j["frames_spread_deg"] = round_to(*e.frames_spread_deg, 1e-4);
  if (e.residual) j["fit_residual"] = round_to(*e.residual, 1e-6);
  if (e.pixels) j["fit_pixels"] = *e.pixels;
  return j;
}

bool is_version_name(const std::string& name) {
  return name.size() == 4 &&
         std::all_of(name.begin(), name.end(), [](unsigned char c) { return std::isdigit(c); });
}

}  // namespace

std::vector<CalibratedLight> combine(const LightCalibration& c) {
  std::vector<CalibratedLight> lights;
  const std::size_t count = std::max(c.chrome.size(), c.matte.size());
  for (std::size_t k = 0; k < count; ++k) {
    CalibratedLight light;
    if (k < c.chrome.size()) {
      light.direction = c.chrome[k].direction;
      light.uncertainty_deg = c.chrome[k].uncertainty_deg;
    } else {
      light.direction = c.matte[k].direction;
      light.uncertainty_deg = c.matte[k].uncertainty_deg;
    }
    if (k < c.matte.size()) light.intensity = c.matte[k].intensity;
    if (k < c.chrome.size() && k < c.matte.size())
      light.chrome_vs_matte_deg = angle_deg(c.chrome[k].direction, c.matte[k].direction);
    lights.push_back(light);
  }
  return lights;
}

json to_json(const LightCalibration& c, const std::string& created) {
  json lights = json::array();
  const auto combined = combine(c);
  for (std::size_t k = 0; k < combined.size(); ++k) {
    const auto& l = combined[k];
    json j = {{"index", k},
              {"direction", vec(l.direction)},
              {"tilt_deg", round_to(tilt_deg(l.direction), 1e-3)},
              {"slant_deg", round_to(slant_deg(l.direction), 1e-3)},
              {"intensity", round_to(l.intensity, 1e-5)},
              {"uncertainty_deg", round_to(l.uncertainty_deg, 1e-4)}};
    if (l.chrome_vs_matte_deg) j["chrome_vs_matte_deg"] = round_to(*l.chrome_vs_matte_deg, 1e-4);
    if (k < c.chrome.size()) j["chrome"] = estimate_json(c.chrome[k]);
    if (k < c.matte.size()) j["matte"] = estimate_json(c.matte[k]);
    lights.push_back(j);
  }
  json spheres = json::object();
  if (c.chrome_sphere) spheres["chrome"] = circle_json(*c.chrome_sphere);
  if (c.matte_sphere) spheres["matte"] = circle_json(*c.matte_sphere);
  return {{"format", kCalibrationFormat},
          {"created", created},
          {"contains", json::array({"lights"})},
          {"lights",
           {{"method", c.method},
            {"projection", c.camera.focal_px ? "perspective" : "orthographic"},
            {"focal_length_px", c.camera.focal_px ? json(*c.camera.focal_px) : json(nullptr)},
            {"spheres", spheres},
            {"sources", c.sources},
            {"per_light", lights}}},
          {"flat", nullptr},
          {"colour", nullptr},
          {"scale", nullptr},
          {"led_positions_mm", nullptr}};
}

Result<StoredCalibration> read_calibration(const fs::path& file) {
  std::ifstream in(file);
  if (!in)
    return std::unexpected(bad_input(
        file, "", "cannot be read; give a calibration.json that `psrig calibrate lights` wrote"));
  StoredCalibration stored;
  stored.file = file;
  try {
    stored.document = json::parse(in);
  } catch (const json::exception& e) {
    return std::unexpected(bad_input(file, "", std::string("is not JSON: ") + e.what()));
  }
  const json& d = stored.document;
  if (!d.is_object() || d.value("format", std::string()) != kCalibrationFormat)
    return std::unexpected(bad_input(file, "format",
                                     std::string("must be \"") + kCalibrationFormat +
                                         "\"; give a calibration.json that `psrig calibrate "
                                         "lights` wrote"));
  if (!d.contains("lights") || !d["lights"].is_object() || !d["lights"].contains("per_light") ||
      !d["lights"]["per_light"].is_array() || d["lights"]["per_light"].empty())
    return std::unexpected(
        bad_input(file, "lights.per_light", "is missing or empty: this calibration has no lights"));
  std::size_t k = 0;
  for (const auto& l : d["lights"]["per_light"]) {
    const std::string key = "lights.per_light[" + std::to_string(k++) + "]";
    CalibratedLight light;
    if (!l.contains("direction") || !l["direction"].is_array() || l["direction"].size() != 3 ||
        !std::all_of(l["direction"].begin(), l["direction"].end(),
                     [](const json& v) { return v.is_number(); }))
      return std::unexpected(bad_input(file, key + ".direction", "must be [x, y, z]"));
    light.direction = {l["direction"][0].get<double>(), l["direction"][1].get<double>(),
                       l["direction"][2].get<double>()};
    if (!(cv::norm(light.direction) > 0) || light.direction[2] <= 0)
      return std::unexpected(
          bad_input(file, key + ".direction", "must point toward the camera's side (z > 0)"));
    light.direction /= cv::norm(light.direction);
    if (l.contains("intensity")) {
      if (!l["intensity"].is_number() || !(l["intensity"].get<double>() > 0))
        return std::unexpected(bad_input(file, key + ".intensity", "must be a positive number"));
      light.intensity = l["intensity"].get<double>();
    }
    light.uncertainty_deg = l.value("uncertainty_deg", 0.0);
    stored.lights.push_back(light);
  }
  if (d.contains("flat") && !d["flat"].is_null()) {
    const json& flat = d["flat"];
    if (!flat.is_object() || !flat.contains("images") || !flat["images"].is_array() ||
        flat["images"].size() != stored.lights.size())
      return std::unexpected(bad_input(file, "flat.images",
                                       "must list one image per light; run psrig calibrate "
                                       "flat again"));
    fs::path base = file.parent_path();
    if (flat.contains("from")) {
      if (!flat["from"].is_string() || !is_version_name(flat["from"].get<std::string>()))
        return std::unexpected(bad_input(file, "flat.from",
                                         "must name a version (\"0001\"); run psrig calibrate "
                                         "flat again"));
      base = base.parent_path() / flat["from"].get<std::string>();
    }
    stored.flat_version = base.filename().string();
    for (const auto& image : flat["images"]) {
      if (!image.is_string())
        return std::unexpected(bad_input(file, "flat.images", "must be file names"));
      const fs::path path = image.get<std::string>();
      stored.flat_images.push_back(path.is_absolute() ? path : base / path);
    }
  }
  if (d.contains("scale") && !d["scale"].is_null()) {
    const json& scale = d["scale"];
    if (!scale.is_object() || !scale.contains("pixel_size_mm") ||
        !scale["pixel_size_mm"].is_number() || !(scale["pixel_size_mm"].get<double>() > 0))
      return std::unexpected(bad_input(file, "scale.pixel_size_mm",
                                       "must be a positive number; run psrig calibrate scale "
                                       "again"));
    stored.pixel_size_mm = scale["pixel_size_mm"].get<double>();
  }
  if (d.contains("led_positions_mm") && !d["led_positions_mm"].is_null()) {
    const json& section = d["led_positions_mm"];
    const auto refuse = [&](const std::string& key) {
      return std::unexpected(bad_input(file, key,
                                       "must list [x, y, z] in mm (z > 0) for each light; run "
                                       "psrig calibrate lights --places 3 again"));
    };
    if (!section.is_object() || !section.contains("positions") ||
        !section["positions"].is_array() || section["positions"].size() != stored.lights.size())
      return refuse("led_positions_mm.positions");
    for (const auto& p : section["positions"]) {
      if (!p.is_array() || p.size() != 3 ||
          !std::all_of(p.begin(), p.end(), [](const json& v) { return v.is_number(); }) ||
          !(p[2].get<double>() > 0))
        return refuse("led_positions_mm.positions");
      stored.led_positions_mm.emplace_back(p[0].get<double>(), p[1].get<double>(),
                                           p[2].get<double>());
    }
  }
  if (d.contains("colour") && !d["colour"].is_null()) {
    const json& colour = d["colour"];
    const auto refuse = [&] {
      return std::unexpected(bad_input(file, "colour.matrix",
                                       "must be 3 rows of 3 finite numbers; run psrig calibrate "
                                       "colour again"));
    };
    if (!colour.is_object() || !colour.contains("matrix") || !colour["matrix"].is_array() ||
        colour["matrix"].size() != 3)
      return refuse();
    cv::Matx33d matrix;
    for (int r = 0; r < 3; ++r) {
      const json& row = colour["matrix"][static_cast<std::size_t>(r)];
      if (!row.is_array() || row.size() != 3) return refuse();
      for (int c = 0; c < 3; ++c) {
        const json& v = row[static_cast<std::size_t>(c)];
        if (!v.is_number() || !std::isfinite(v.get<double>())) return refuse();
        matrix(r, c) = v.get<double>();
      }
    }
    stored.colour_matrix = matrix;
    if (colour.contains("flat_field") && colour["flat_field"].is_string())
      stored.colour_flat_field = colour["flat_field"].get<std::string>();
    // The version that measured it: its own, or the one it was carried from.
    stored.colour_version = colour.contains("from") && colour["from"].is_string()
                                ? colour["from"].get<std::string>()
                                : file.parent_path().filename().string();
  }
  return stored;
}

Result<json> carry_forward(const StoredCalibration& current, const std::string& measured) {
  json next = current.document;
  const std::string version = current.file.parent_path().filename().string();
  if (!is_version_name(version))
    return std::unexpected(bad_input(current.file, "",
                                     "is not in a calibration store; give the rig's current "
                                     "calibration"));
  json contains = json::array();
  for (const char* section : {"lights", "flat", "colour", "scale", "led_positions_mm"}) {
    if (section == measured) {
      contains.push_back(section);
      continue;
    }
    if (!next.contains(section) || next[section].is_null()) {
      next[section] = nullptr;
      continue;
    }
    contains.push_back(section);
    if (next[section].is_object() && !next[section].contains("from"))
      next[section]["from"] = version;
  }
  next["contains"] = contains;
  next["created"] = utc_now();
  return next;
}

std::string utc_now() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

Status write_new_file(const fs::path& file, const std::string& text) {
  std::error_code ec;
  if (fs::exists(fs::symlink_status(file, ec)))
    return std::unexpected(
        bad_input(file, "", "exists already; give another file, or remove it first"));
  const fs::path parent = file.parent_path().empty() ? fs::path(".") : file.parent_path();
  if (!fs::is_directory(parent, ec))
    return std::unexpected(bad_input(file, "", "its folder does not exist; create it first"));
  const fs::path temporary =
      parent / ("." + file.filename().string() + ".tmp" + std::to_string(getpid()));
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0)
    return std::unexpected(
        io_error(temporary, "cannot create: " + std::generic_category().message(errno)));
  std::size_t written = 0;
  while (written < text.size()) {
    const ssize_t n = ::write(fd, text.data() + written, text.size() - written);
    if (n <= 0) {
      const int error = errno;
      ::close(fd);
      fs::remove(temporary, ec);
      return std::unexpected(
          io_error(temporary, "cannot write: " + std::generic_category().message(error)));
    }
    written += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    fs::remove(temporary, ec);
    return std::unexpected(io_error(temporary, "cannot flush to disk"));
  }
  // Refuses to replace a file that appeared meanwhile.
  if (::renameat2(AT_FDCWD, temporary.c_str(), AT_FDCWD, file.c_str(), RENAME_NOREPLACE) != 0) {
    const int error = errno;
    fs::remove(temporary, ec);
    if (error == EEXIST)
      return std::unexpected(
          bad_input(file, "", "exists already; give another file, or remove it first"));
    return std::unexpected(
        io_error(file, "cannot rename into place: " + std::generic_category().message(error)));
  }
  return {};
}

std::vector<fs::path> CalibrationStore::versions() const {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(directory_, ec))
    if (is_version_name(entry.path().filename().string()) && entry.is_directory(ec))
      out.push_back(entry.path());
  std::sort(out.begin(), out.end());
  return out;
}

std::optional<fs::path> CalibrationStore::current() const {
  auto all = versions();
  for (auto it = all.rbegin(); it != all.rend(); ++it) {
    std::error_code ec;
    if (fs::is_regular_file(*it / kCalibrationFile, ec)) return *it / kCalibrationFile;
  }
  return std::nullopt;
}

Result<formats::AtomicDirectory> CalibrationStore::begin_next() const {
  std::error_code ec;
  fs::create_directories(directory_, ec);
  if (ec)
    return std::unexpected(
        io_error(directory_, "cannot create the calibration store: " + ec.message()));
  const auto all = versions();
  int next = all.empty() ? 1 : std::stoi(all.back().filename().string()) + 1;
  if (next > 9999)
    return std::unexpected(io_error(directory_, "holds 9999 calibrations; archive some"));
  char name[16];
  std::snprintf(name, sizeof name, "%04d", next);
  return formats::AtomicDirectory::create(directory_ / name);
}

}  // namespace psrig::calibration
