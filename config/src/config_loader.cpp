#include "psrig/config/config_loader.h"

#include <algorithm>
#include <arpa/inet.h>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>
#include <optional>
#include <set>
#include <sstream>
#include <toml++/toml.h>

namespace psrig::config {
namespace {

// A TOML integer's value; nothing for any other node. (toml++'s value<int64_t>()
// also converts a float, which is undefined behaviour past 2^63.)
std::optional<std::int64_t> integer_of(const toml::node& n) {
  if (const auto* integer = n.as_integer()) return integer->get();
  return std::nullopt;
}

namespace fs = std::filesystem;

// Levenshtein distance, for "did you mean" on unknown keys.
std::size_t distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j)
    row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t previous = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t substitution = previous + (a[i - 1] == b[j - 1] ? 0 : 1);
      previous = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, substitution});
    }
  }
  return row[b.size()];
}

// Reads one TOML table against what psrig knows of it: each get() consumes
// a key; finish() reports the keys left over as warnings.
class Section {
 public:
  Section(const toml::table* table, std::string path, const fs::path& file,
          std::vector<std::string>* warnings)
      : table_(table), path_(std::move(path)), file_(file), warnings_(warnings) {}

  [[nodiscard]] std::string key(const std::string& name) const {
    return path_.empty() ? name : path_ + "." + name;
  }

  Error error_at(const toml::node* node, const std::string& name,
                 const std::string& message) const {
    Error e = bad_input(file_, key(name), message);
    if (node) {
      e.line = static_cast<int>(node->source().begin.line);
      e.column = static_cast<int>(node->source().begin.column);
    }
    return e;
  }

  const toml::node* node(const std::string& name) {
    known_.insert(name);
    return table_ ? table_->get(name) : nullptr;
  }

  Status get(const std::string& name, double& out, double min, double max,
             bool exclusive_min = false) {
    const toml::node* n = node(name);
    if (!n) return {};
    const auto value = n->value<double>();  // integers convert too
    if (!value) return std::unexpected(error_at(n, name, "expected a number"));
    if (*value < min || *value > max || (exclusive_min && *value == min))
      return std::unexpected(
          error_at(n, name,
                   "is " + format(*value) + "; expected " +
                       (exclusive_min ? "more than " : "from ") + format(min) +
                       (max < 1e300 ? (exclusive_min ? ", at most " : " to ") + format(max) : "")));
    out = *value;
    return {};
  }

  Status get(const std::string& name, int& out, long min, long max) {
    const toml::node* n = node(name);
    if (!n) return {};
    const auto value = integer_of(*n);
    if (!value) return std::unexpected(error_at(n, name, "expected a whole number"));
    if (*value < min || *value > max)
      return std::unexpected(error_at(n, name,
                                      "is " + std::to_string(*value) + "; expected " +
                                          std::to_string(min) + " to " + std::to_string(max)));
    out = static_cast<int>(*value);
    return {};
  }

  Status get(const std::string& name, std::uint64_t& out) {
    const toml::node* n = node(name);
    if (!n) return {};
    const auto value = integer_of(*n);
    if (!value || *value < 0)
      return std::unexpected(error_at(n, name, "expected a whole number, 0 or more"));
    out = static_cast<std::uint64_t>(*value);
    return {};
  }

  Status get(const std::string& name, bool& out) {
    const toml::node* n = node(name);
    if (!n) return {};
    if (!n->is_boolean()) return std::unexpected(error_at(n, name, "expected true or false"));
    out = *n->value<bool>();
    return {};
  }

  Status get(const std::string& name, std::string& out,
             std::initializer_list<const char*> allowed = {}) {
    const toml::node* n = node(name);
    if (!n) return {};
    if (!n->is_string()) return std::unexpected(error_at(n, name, "expected a string"));
    const std::string value = *n->value<std::string>();
    if (allowed.size() > 0 &&
        std::none_of(allowed.begin(), allowed.end(), [&](const char* a) { return value == a; })) {
      std::string list;
      for (const char* a : allowed)
        list += (list.empty() ? "\"" : ", \"") + std::string(a) + "\"";
      return std::unexpected(error_at(n, name, "is \"" + value + "\"; expected one of " + list));
    }
    out = value;
    return {};
  }

  Status get(const std::string& name, std::vector<double>& out, double min, double max) {
    const toml::node* n = node(name);
    if (!n) return {};
    const toml::array* array = n->as_array();
    if (!array) return std::unexpected(error_at(n, name, "expected an array of numbers"));
    std::vector<double> values;
    for (const auto& element : *array) {
      const auto value = element.value<double>();
      if (!value) return std::unexpected(error_at(&element, name, "expected an array of numbers"));
      if (*value < min || *value > max)
        return std::unexpected(error_at(&element, name,
                                        "has " + format(*value) + "; expected values from " +
                                            format(min) + " to " + format(max)));
      values.push_back(*value);
    }
    out = std::move(values);
    return {};
  }

  // An array of [x, y, z] triples, each coordinate within [min, max] and z above z_min.
  Status get(const std::string& name, std::vector<std::array<double, 3>>& out, double limit,
             double z_min) {
    const toml::node* n = node(name);
    if (!n) return {};
    const toml::array* array = n->as_array();
    if (!array) return std::unexpected(error_at(n, name, "expected an array of [x, y, z] arrays"));
    std::vector<std::array<double, 3>> values;
    for (const auto& element : *array) {
      const toml::array* triple = element.as_array();
      if (!triple || triple->size() != 3)
        return std::unexpected(error_at(&element, name, "expected [x, y, z] in millimetres"));
      std::array<double, 3> v{};
      for (std::size_t i = 0; i < 3; ++i) {
        const auto value = (*triple)[i].value<double>();
        if (!value || !std::isfinite(*value) || std::abs(*value) > limit)
          return std::unexpected(error_at(
              &element, name, "expected [x, y, z] with numbers within ±" + format(limit) + " mm"));
        v[i] = *value;
      }
      if (v[2] <= z_min)
        return std::unexpected(error_at(
            &element, name,
            "has z = " + format(v[2]) + "; an LED must be above the swatch plane (z > 0)"));
      values.push_back(v);
    }
    out = std::move(values);
    return {};
  }

  Status get(const std::string& name, std::vector<unsigned>& out) {
    const toml::node* n = node(name);
    if (!n) return {};
    const toml::array* array = n->as_array();
    if (!array) return std::unexpected(error_at(n, name, "expected an array of whole numbers"));
    std::vector<unsigned> values;
    for (const auto& element : *array) {
      const auto value = integer_of(element);
      if (!value || *value < 0 || *value > std::numeric_limits<unsigned>::max())
        return std::unexpected(error_at(&element, name,
                                        "expected whole numbers, 0 to " +
                                            std::to_string(std::numeric_limits<unsigned>::max())));
      values.push_back(static_cast<unsigned>(*value));
    }
    out = std::move(values);
    return {};
  }

  Status get(const std::string& name, std::vector<std::string>& out) {
    const toml::node* n = node(name);
    if (!n) return {};
    const toml::array* array = n->as_array();
    if (!array) return std::unexpected(error_at(n, name, "expected an array of strings"));
    std::vector<std::string> values;
    for (const auto& element : *array) {
      if (!element.is_string())
        return std::unexpected(error_at(&element, name, "expected an array of strings"));
      values.push_back(*element.value<std::string>());
    }
    out = std::move(values);
    return {};
  }

  // A warning about `name` (at its line when present), as finish() words them.
  void warn(const std::string& name, const std::string& message) const {
    if (!warnings_) return;
    std::ostringstream line;
    line << file_.string();
    if (const toml::node* n = find(name))
      line << ":" << n->source().begin.line << ":" << n->source().begin.column;
    line << ": " << key(name) << ": " << message;
    warnings_->push_back(line.str());
  }

  // A sub-table, or nullptr when absent; an error when `name` is not a table.
  Result<const toml::table*> table(const std::string& name) {
    const toml::node* n = node(name);
    if (!n) return nullptr;
    if (!n->is_table())
      return std::unexpected(error_at(n, name, "expected a table ([" + key(name) + "])"));
    return n->as_table();
  }

  void finish() const {
    if (!table_ || !warnings_) return;
    for (const auto& [name, value] : *table_) {
      const std::string k(name.str());
      if (known_.contains(k)) continue;
      std::string nearest;
      std::size_t best = 3;  // only suggest close spellings
      for (const auto& known : known_)
        if (const std::size_t d = distance(k, known); d < best) best = d, nearest = known;
      std::ostringstream line;
      line << file_.string() << ":" << name.source().begin.line << ":" << name.source().begin.column
           << ": " << key(k) << ": unknown key, ignored"
           << (nearest.empty() ? "" : " (did you mean '" + key(nearest) + "'?)");
      warnings_->push_back(line.str());
    }
  }

  [[nodiscard]] const toml::node* find(const std::string& name) const {
    return table_ ? table_->get(name) : nullptr;
  }

 private:
  static std::string format(double value) {
    std::ostringstream s;
    s << value;
    return s.str();
  }

  const toml::table* table_;
  std::string path_;
  fs::path file_;
  std::vector<std::string>* warnings_;
  std::set<std::string> known_;
};

#define PSRIG_TRY(expression)                                                           \
  do {                                                                                  \
    if (auto status_ = (expression); !status_) return std::unexpected(status_.error()); \
  } while (false)

constexpr double kNoMax = 1e308;

// Why `name` cannot name a rig (it becomes a directory under the shared
// storage root), or nothing.
std::optional<std::string> rig_name_problem(const std::string& name) {
  if (name.empty()) return "is empty";
  if (name.size() > 64) return "is longer than 64 characters";
  if (name.front() == '.') return "begins with '.'";
  for (const char ch : name)
    if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '.' && ch != '-' && ch != '_')
      return std::string("holds '") + ch + "'";
  return std::nullopt;
}

// A path the file gives: absolute as written, relative to the file's folder.
fs::path relative_to_file(const fs::path& file, const std::string& text) {
  return fs::path(text).is_absolute() ? fs::path(text)
                                      : (file.parent_path() / text).lexically_normal();
}

Result<RigConfig> read(const toml::table& root, const fs::path& file,
                       std::vector<std::string>* warnings) {
  RigConfig c;
  c.source = file;
  Section top(&root, "", file, warnings);
  const auto sub = [&](Section& parent, const std::string& name) -> Result<Section> {
    auto table = parent.table(name);
    if (!table) return std::unexpected(table.error());
    return Section(*table, parent.key(name), file, warnings);
  };

  auto geometry = sub(top, "geometry");
  if (!geometry) return std::unexpected(geometry.error());
  PSRIG_TRY(geometry->get("slant_deg", c.geometry.slant_deg, 0, 89, true));
  PSRIG_TRY(geometry->get("tilts_deg", c.geometry.tilts_deg, -360, 360));
  PSRIG_TRY(geometry->get("working_distance_mm", c.geometry.working_distance_mm, 0, kNoMax, true));
  double pixel_size = 0;
  if (geometry->find("pixel_size_mm")) {
    PSRIG_TRY(geometry->get("pixel_size_mm", pixel_size, 0, kNoMax, true));
    c.geometry.pixel_size_mm = pixel_size;
  } else {
    geometry->node("pixel_size_mm");
  }
  PSRIG_TRY(geometry->get("led_positions_mm", c.geometry.led_positions_mm, 1e5, 0));
  if (geometry->find("led_distance_mm")) {
    double distance = 0;
    PSRIG_TRY(geometry->get("led_distance_mm", distance, 0, 1e5, true));
    c.geometry.led_distance_mm = distance;
    if (geometry->find("led_positions_mm"))
      return std::unexpected(
          geometry->error_at(geometry->find("led_distance_mm"), "led_distance_mm",
                             "give either led_positions_mm or led_distance_mm, not both"));
  } else {
    geometry->node("led_distance_mm");
  }
  PSRIG_TRY(geometry->get("swatch_height_mm", c.geometry.swatch_height_mm, 0, 1000));
  geometry->finish();

  auto lights = sub(top, "lights");
  if (!lights) return std::unexpected(lights.error());
  PSRIG_TRY(lights->get("backend", c.lights.backend, {"gpiod", "usb", "modbus", "sim"}));
  PSRIG_TRY(lights->get("channels", c.lights.channels, 3, 16));
  PSRIG_TRY(lights->get("intensity", c.lights.intensity, 0, 1));
  PSRIG_TRY(lights->get("max_on_ms", c.lights.max_on_ms, 1, 600000));
  {
    auto gpiod = sub(*lights, "gpiod");
    if (!gpiod) return std::unexpected(gpiod.error());
    PSRIG_TRY(gpiod->get("chip", c.lights.gpiod.chip));
    PSRIG_TRY(gpiod->get("lines", c.lights.gpiod.lines));
    PSRIG_TRY(gpiod->get("active_low", c.lights.gpiod.active_low));
    PSRIG_TRY(gpiod->get("consumer", c.lights.gpiod.consumer));
    gpiod->finish();
    if (c.lights.backend == "gpiod" &&
        c.lights.gpiod.lines.size() != static_cast<std::size_t>(c.lights.channels))
      return std::unexpected(
          gpiod->error_at(gpiod->find("lines"), "lines",
                          "gives " + std::to_string(c.lights.gpiod.lines.size()) +
                              " line offsets for " + std::to_string(c.lights.channels) +
                              " channels; list one GPIO line per LED (see `gpioinfo`)"));

    auto usb = sub(*lights, "usb");
    if (!usb) return std::unexpected(usb.error());
    int vendor = c.lights.usb.vendor_id, product = c.lights.usb.product_id;
    PSRIG_TRY(usb->get("vendor_id", vendor, 0, 0xFFFF));
    PSRIG_TRY(usb->get("product_id", product, 0, 0xFFFF));
    c.lights.usb.vendor_id = static_cast<std::uint16_t>(vendor);
    c.lights.usb.product_id = static_cast<std::uint16_t>(product);
    PSRIG_TRY(usb->get("serial", c.lights.usb.serial));
    PSRIG_TRY(usb->get("timeout_ms", c.lights.usb.timeout_ms, 1, 60000));
    PSRIG_TRY(usb->get("watchdog_ms", c.lights.usb.watchdog_ms, 10, 60000));
    usb->finish();

    auto modbus = sub(*lights, "modbus");
    if (!modbus) return std::unexpected(modbus.error());
    auto& m = c.lights.modbus;
    PSRIG_TRY(modbus->get("transport", m.transport, {"tcp", "rtu"}));
    PSRIG_TRY(modbus->get("device", m.device));
    PSRIG_TRY(modbus->get("baud", m.baud, 300, 4000000));
    std::string parity(1, m.parity);
    PSRIG_TRY(modbus->get("parity", parity, {"N", "E", "O"}));
    m.parity = parity[0];
    PSRIG_TRY(modbus->get("data_bits", m.data_bits, 5, 8));
    PSRIG_TRY(modbus->get("stop_bits", m.stop_bits, 1, 2));
    PSRIG_TRY(modbus->get("host", m.host));
    PSRIG_TRY(modbus->get("port", m.port, 1, 65535));
    PSRIG_TRY(modbus->get("slave", m.slave, 0, 247));
    PSRIG_TRY(modbus->get("timeout_ms", m.timeout_ms, 1, 60000));
    PSRIG_TRY(modbus->get("retries", m.retries, 0, 10));
    {
      auto registers = sub(*modbus, "registers");
      if (!registers) return std::unexpected(registers.error());
      PSRIG_TRY(registers->get("enable_coil", m.registers.enable_coil, 0, 65535));
      PSRIG_TRY(registers->get("all_off_coil", m.registers.all_off_coil, -1, 65535));
      PSRIG_TRY(registers->get("intensity_register", m.registers.intensity_register, 0, 65535));
      PSRIG_TRY(registers->get("intensity_full_scale", m.registers.intensity_full_scale, 1, 65535));
      PSRIG_TRY(registers->get("status_register", m.registers.status_register, 0, 65535));
      PSRIG_TRY(registers->get("id_register", m.registers.id_register, -1, 65534));
      PSRIG_TRY(registers->get("device_id", m.registers.device_id, 0, 65535));
      registers->finish();
    }
    modbus->finish();

    auto sim_lights = sub(*lights, "sim");
    if (!sim_lights) return std::unexpected(sim_lights.error());
    std::string switch_log;
    PSRIG_TRY(sim_lights->get("switch_log", switch_log));
    // Relative to the configuration file, as storage.root is.
    if (!switch_log.empty()) c.lights.sim.switch_log = relative_to_file(file, switch_log);
    sim_lights->finish();
  }
  lights->finish();
  if (!c.lights.intensity.empty() &&
      c.lights.intensity.size() != static_cast<std::size_t>(c.lights.channels))
    return std::unexpected(lights->error_at(lights->find("intensity"), "intensity",
                                            "gives " + std::to_string(c.lights.intensity.size()) +
                                                " values for " + std::to_string(c.lights.channels) +
                                                " channels"));
  if (geometry->find("tilts_deg") &&
      c.geometry.tilts_deg.size() != static_cast<std::size_t>(c.lights.channels))
    return std::unexpected(
        geometry->error_at(geometry->find("tilts_deg"), "tilts_deg",
                           "gives " + std::to_string(c.geometry.tilts_deg.size()) + " tilts for " +
                               std::to_string(c.lights.channels) + " lights (lights.channels)"));
  if (geometry->find("led_positions_mm") &&
      c.geometry.led_positions_mm.size() != static_cast<std::size_t>(c.lights.channels))
    return std::unexpected(geometry->error_at(
        geometry->find("led_positions_mm"), "led_positions_mm",
        "gives " + std::to_string(c.geometry.led_positions_mm.size()) + " positions for " +
            std::to_string(c.lights.channels) + " lights (lights.channels)"));
  if (!geometry->find("tilts_deg") && c.lights.channels != 3) {
    c.geometry.tilts_deg.clear();  // evenly spread, one per channel
    for (int k = 0; k < c.lights.channels; ++k)
      c.geometry.tilts_deg.push_back(360.0 * k / c.lights.channels);
  }

  auto camera = sub(top, "camera");
  if (!camera) return std::unexpected(camera.error());
  auto& cam = c.camera;
  PSRIG_TRY(camera->get("backend", cam.backend, {"v4l2", "libcamera", "sim"}));
  PSRIG_TRY(camera->get("device", cam.device));
  PSRIG_TRY(camera->get("format", cam.format));
  PSRIG_TRY(camera->get("width", cam.width, 0, 65535));
  PSRIG_TRY(camera->get("height", cam.height, 0, 65535));
  PSRIG_TRY(camera->get("exposure_us", cam.exposure_us, 1, 60000000));
  PSRIG_TRY(camera->get("gain", cam.gain, 0, 1000, true));
  PSRIG_TRY(camera->get("frames_average", cam.frames_average, 1, 64));
  PSRIG_TRY(camera->get("frames_discard", cam.frames_discard, 0, 64));
  PSRIG_TRY(camera->get("timeout_ms", cam.timeout_ms, 1, 600000));
  {
    std::vector<double> point;
    PSRIG_TRY(camera->get("principal_point_px", point, 0, 65535));
    if (camera->find("principal_point_px")) {
      if (point.size() != 2)
        return std::unexpected(camera->error_at(
            camera->find("principal_point_px"), "principal_point_px",
            "expected [x, y] in pixels (where the camera axis meets the image, from the "
            "top-left corner); leave it out for the image centre"));
      cam.principal_point_px = std::array<double, 2>{point[0], point[1]};
    }
  }
  camera->finish();

  auto capture = sub(top, "capture");
  if (!capture) return std::unexpected(capture.error());
  PSRIG_TRY(capture->get("dark_frame", c.capture.dark_frame));
  PSRIG_TRY(capture->get("settle_ms", c.capture.settle_ms, 0, 60000));
  PSRIG_TRY(capture->get("process", c.capture.process));
  capture->finish();

  auto processing = sub(top, "processing");
  if (!processing) return std::unexpected(processing.error());
  PSRIG_TRY(processing->get("reject", c.processing.reject));
  processing->finish();

  auto calibration = sub(top, "calibration");
  if (!calibration) return std::unexpected(calibration.error());
  PSRIG_TRY(calibration->get("max_age_days", c.calibration.max_age_days, 0, 36500));
  if (calibration->find("sphere_diameter_mm")) {
    double diameter = 0;
    PSRIG_TRY(calibration->get("sphere_diameter_mm", diameter, 0, 1000, true));
    c.calibration.sphere_diameter_mm = diameter;
  } else {
    calibration->node("sphere_diameter_mm");
  }
  calibration->finish();

  auto storage = sub(top, "storage");
  if (!storage) return std::unexpected(storage.error());
  std::string storage_root = c.storage.root.string();
  PSRIG_TRY(storage->get("root", storage_root));
  PSRIG_TRY(
      storage->get("exr_compression", c.storage.exr_compression, {"auto", "zip", "piz", "none"}));
  PSRIG_TRY(storage->get("png_level", c.storage.png_level, 0, 9));
  PSRIG_TRY(storage->get("map_precision", c.storage.map_precision, {"half", "float"}));
  // Relative to the configuration file, not to wherever psrig was started.
  c.storage.root = relative_to_file(file, storage_root);
  storage->finish();

  auto sim = sub(top, "sim");
  if (!sim) return std::unexpected(sim.error());
  auto& s = c.sim;
  PSRIG_TRY(sim->get("target", s.target,
                     {"swatch", "flat", "chrome_sphere", "matte_sphere", "white_card",
                      "charuco_board", "colour_chart"}));
  // "flat", the older name of a grey card: the white card at albedo 0.6.
  if (s.target == "flat") {
    s.target = "white_card";
    s.card_albedo = 0.6;
  }
  PSRIG_TRY(sim->get("card_albedo", s.card_albedo, 0, 1, true));
  PSRIG_TRY(sim->get("sphere_diameter_mm", s.sphere_diameter_mm, 0.1, 1000, true));
  PSRIG_TRY(sim->get("led_angular_diameter_deg", s.led_angular_diameter_deg, 0.01, 20, true));
  {
    std::vector<double> centre;
    PSRIG_TRY(sim->get("sphere_centre_mm", centre, -1e4, 1e4));
    if (sim->find("sphere_centre_mm")) {
      if (centre.size() != 2)
        return std::unexpected(
            sim->error_at(sim->find("sphere_centre_mm"), "sphere_centre_mm",
                          "expected [x, y] in millimetres from the camera axis"));
      s.sphere_centre_mm = std::array<double, 2>{centre[0], centre[1]};
    }
  }
  if (const toml::node* places = sim->node("sphere_places_mm")) {
    const toml::array* array = places->as_array();
    if (!array || array->empty())
      return std::unexpected(
          sim->error_at(places, "sphere_places_mm",
                        "expected a list of [x, y] places in millimetres "
                        "from the camera axis, e.g. [[-8, 5], [8, 5], [0, -7]]"));
    for (const auto& element : *array) {
      const toml::array* pair = element.as_array();
      std::optional<double> x, y;
      if (pair && pair->size() == 2) x = (*pair)[0].value<double>(), y = (*pair)[1].value<double>();
      if (!x || !y || std::abs(*x) > 1e4 || std::abs(*y) > 1e4)
        return std::unexpected(sim->error_at(
            &element, "sphere_places_mm", "expected [x, y] in millimetres from the camera axis"));
      s.sphere_places_mm.push_back({*x, *y});
    }
  }
  if (sim->find("led_distance_mm")) {
    double distance = 0;
    PSRIG_TRY(sim->get("led_distance_mm", distance, 0, 1e5, true));
    s.led_distance_mm = distance;
  } else {
    sim->node("led_distance_mm");
  }
  {
    std::vector<double> mixing;
    PSRIG_TRY(sim->get("colour_matrix", mixing, -10, 10));
    if (sim->find("colour_matrix")) {
      if (mixing.size() != 9)
        return std::unexpected(sim->error_at(
            sim->find("colour_matrix"), "colour_matrix",
            "expected 9 numbers, the 3x3 matrix from the scene's linear sRGB to the camera's "
            "RGB row by row (e.g. [0.7, 0.25, 0.05, 0.1, 0.8, 0.1, 0.02, 0.28, 0.7])"));
      std::array<double, 9> m{};
      std::copy(mixing.begin(), mixing.end(), m.begin());
      s.colour_matrix = m;
    }
  }
  PSRIG_TRY(sim->get("pattern", s.pattern));
  {
    // A file is found from the rig.toml's folder; a name in patterns_dir,
    // when the simulated world is made (sim/swatch_pattern.h).
    const fs::path given(s.pattern);
    if (s.pattern.empty())
      return std::unexpected(
          sim->error_at(sim->find("pattern"), "pattern",
                        "is empty; give a .chart or .weave file or a shipped pattern's name, e.g. "
                        "\"stockinette\""));
    if (s.pattern.find('/') != std::string::npos || given.extension() == ".chart" ||
        given.extension() == ".weave") {
      s.pattern = relative_to_file(file, s.pattern).string();
      std::error_code ec;
      if (!fs::is_regular_file(s.pattern, ec))
        return std::unexpected(sim->error_at(
            sim->find("pattern"), "pattern",
            "\"" + s.pattern +
                "\" is not a file; give a .chart or .weave file (relative to this rig.toml) or a "
                "shipped pattern's name, e.g. \"stockinette\""));
    }
    std::string patterns_dir;
    PSRIG_TRY(sim->get("patterns_dir", patterns_dir));
    if (!patterns_dir.empty()) {
      s.patterns_dir = relative_to_file(file, patterns_dir);
      std::error_code ec;
      if (!fs::is_directory(s.patterns_dir, ec))
        return std::unexpected(sim->error_at(
            sim->find("patterns_dir"), "patterns_dir",
            "\"" + s.patterns_dir.string() +
                "\" is not a folder; point it at the shipped patterns (config/patterns) or "
                "leave it out"));
    }
  }
  PSRIG_TRY(sim->get("swatch_rotation_deg", s.swatch_rotation_deg, -45, 45));
  PSRIG_TRY(sim->get("seed", s.seed));
  PSRIG_TRY(sim->get("width", s.width, 8, 16384));
  PSRIG_TRY(sim->get("height", s.height, 8, 16384));
  PSRIG_TRY(sim->get("pixel_size_mm", s.pixel_size_mm, 0, 1, true));
  PSRIG_TRY(sim->get("bit_depth", s.bit_depth, 8, 16));
  PSRIG_TRY(sim->get("full_well", s.full_well, 1, 1e7));
  PSRIG_TRY(sim->get("read_noise", s.read_noise, 0, 1000));
  PSRIG_TRY(sim->get("black_level", s.black_level, 0, 65535));
  PSRIG_TRY(sim->get("ambient", s.ambient, 0, 10));
  PSRIG_TRY(sim->get("vignetting", s.vignetting, 0, 0.9));
  PSRIG_TRY(sim->get("led_irradiance", s.led_irradiance, 0, 100));
  PSRIG_TRY(sim->get("readout_us", s.readout_us, 0, 10000000));
  PSRIG_TRY(sim->get("frame_interval_us", s.frame_interval_us, 0, 60000000));
  sim->finish();
  if (s.black_level >= (1 << s.bit_depth) - 1)
    return std::unexpected(sim->error_at(sim->find("black_level"), "black_level",
                                         "must be below the " + std::to_string(s.bit_depth) +
                                             "-bit full scale (" +
                                             std::to_string((1 << s.bit_depth) - 1) + ")"));
  if (c.camera.backend == "sim" && c.geometry.pixel_size_mm == std::nullopt)
    c.geometry.pixel_size_mm = s.pixel_size_mm;

  auto daemon = sub(top, "daemon");
  if (!daemon) return std::unexpected(daemon.error());
  auto& d = c.daemon;
  PSRIG_TRY(daemon->get("listen_address", d.listen_address));
  PSRIG_TRY(daemon->get("port", d.port, 1, 65535));
  PSRIG_TRY(daemon->get("token", d.token));
  PSRIG_TRY(daemon->get("queue_limit", d.queue_limit, 1, 10000));
  PSRIG_TRY(daemon->get("modbus_address", d.modbus_address));
  PSRIG_TRY(daemon->get("modbus_port", d.modbus_port, 0, 65535));
  PSRIG_TRY(daemon->get("modbus_allow", d.modbus_allow));
  std::string web_root;
  PSRIG_TRY(daemon->get("web_root", web_root));
  PSRIG_TRY(daemon->get("rig_name", d.rig_name));
  PSRIG_TRY(daemon->get("role", d.role, {"rig", "catalogue"}));
  PSRIG_TRY(daemon->get("public_url", d.public_url));
  daemon->finish();
  if (!daemon->find("rig_name")) d.rig_name = host_name();
  if (auto problem = rig_name_problem(d.rig_name))
    return std::unexpected(daemon->error_at(
        daemon->find("rig_name"), "rig_name",
        (daemon->find("rig_name") ? "\"" + d.rig_name + "\" " : "the hostname \"" + d.rig_name +
                                                                     "\" ") +
            *problem + "; set rig_name to letters, digits, '.', '-' or '_' (e.g. \"rig-1\")"));
  if (d.public_url.empty()) {
    const bool everywhere = d.listen_address == "0.0.0.0" || d.listen_address == "::";
    std::string host = everywhere ? host_name() : d.listen_address;
    if (host.find(':') != std::string::npos) host = "[" + host + "]";
    d.public_url = "http://" + host + ":" + std::to_string(d.port);
  } else if (!d.public_url.starts_with("http://") && !d.public_url.starts_with("https://")) {
    return std::unexpected(daemon->error_at(
        daemon->find("public_url"), "public_url",
        "\"" + d.public_url +
            "\" is not an http:// or https:// URL; give the address other psrigd reach this "
            "one's API at, e.g. \"http://rig-1.lab:8470\""));
  }
  if (!web_root.empty()) {
    d.web_root = relative_to_file(file, web_root);
    if (!std::filesystem::is_regular_file(d.web_root / "index.html"))
      return std::unexpected(daemon->error_at(
          daemon->find("web_root"), "web_root",
          "\"" + d.web_root.string() +
              "\" holds no index.html; build the catalogue (scripts/build) and point web_root "
              "at its output (build/web), or leave web_root out"));
  }
  for (std::size_t i = 0; i < d.modbus_allow.size(); ++i) {
    in_addr parsed{};
    if (::inet_pton(AF_INET, d.modbus_allow[i].c_str(), &parsed) != 1)
      return std::unexpected(
          daemon->error_at(daemon->find("modbus_allow")->as_array()->get(i), "modbus_allow",
                           "\"" + d.modbus_allow[i] +
                               "\" is not an IPv4 address; list the PLCs that may connect, e.g. "
                               "[\"192.0.2.10\"]"));
  }
  for (const auto& [key, value] :
       {std::pair<const char*, const std::string&>{"listen_address", d.listen_address},
        {"modbus_address", d.modbus_address}})
    if (value.empty())
      return std::unexpected(daemon->error_at(daemon->find(key), key,
                                              "is empty; give an address such as \"127.0.0.1\""));
  // Anyone who can reach the port could drive the rig: off this machine,
  // only with a token worth guessing.
  constexpr std::size_t kMinTokenLength = 16;
  if (!d.token.empty() && d.token.size() < kMinTokenLength)
    return std::unexpected(daemon->error_at(
        daemon->find("token"), "token",
        "is " + std::to_string(d.token.size()) + " characters; use " +
            std::to_string(kMinTokenLength) + " or more (e.g. `openssl rand -hex 24`)"));
  if (d.token.empty() && !is_loopback_address(d.listen_address))
    return std::unexpected(daemon->error_at(
        daemon->find("listen_address"), "listen_address",
        "is \"" + d.listen_address +
            "\", reachable from other machines, but daemon.token is not set; set a token "
            "(e.g. `openssl rand -hex 24`) or listen on 127.0.0.1"));
  // The Modbus server has no authentication: whoever reaches it can
  // trigger scans and turn the lights off.
  if (d.modbus_port != 0 && d.modbus_allow.empty() && !is_loopback_address(d.modbus_address))
    daemon->warn("modbus_address",
                 "is \"" + d.modbus_address +
                     "\", reachable from other machines, and daemon.modbus_allow is empty: "
                     "anyone who can reach port " +
                     std::to_string(d.modbus_port) +
                     " can trigger scans and turn the lights off (Modbus has no "
                     "authentication); list the PLC in daemon.modbus_allow (e.g. "
                     "modbus_allow = [\"192.0.2.10\"]) or listen on 127.0.0.1");

  auto catalogue = sub(top, "catalogue");
  if (!catalogue) return std::unexpected(catalogue.error());
  PSRIG_TRY(catalogue->get("url", c.catalogue.url));
  std::string journal;
  PSRIG_TRY(catalogue->get("journal", journal));
  catalogue->finish();
  if (!c.catalogue.url.empty() && c.catalogue.url != "sqlite" && !is_shared_catalogue(c.catalogue))
    return std::unexpected(catalogue->error_at(
        catalogue->find("url"), "url",
        "\"" + c.catalogue.url +
            "\" is neither \"sqlite\" (the embedded catalogue, the default) nor a PostgreSQL "
            "URL; give e.g. \"postgresql://psrig@db.lab/psrig\" or leave url out"));
  // Each rig of a shared catalogue writes under its own prefix of the
  // shared storage root; a catalogue-only psrigd writes no scans.
  c.storage.shared_root = c.storage.root;
  if (is_shared_catalogue(c.catalogue) && d.role == "rig")
    c.storage.root = c.storage.shared_root / d.rig_name;
  if (!journal.empty())
    c.catalogue.journal = relative_to_file(file, journal);
  else if (is_shared_catalogue(c.catalogue) && d.role == "rig")
    c.catalogue.journal = c.storage.root / "catalogue-journal.json";

  top.finish();
  return c;
}

}  // namespace

Result<RigConfig> parse_config(std::string_view text, const fs::path& source,
                               std::vector<std::string>* warnings) {
  try {
    const toml::table root = toml::parse(text, source.string());
    return read(root, source, warnings);
  } catch (const toml::parse_error& e) {
    Error error =
        bad_input(source, "", std::string("malformed TOML: ") + std::string(e.description()));
    error.line = static_cast<int>(e.source().begin.line);
    error.column = static_cast<int>(e.source().begin.column);
    return std::unexpected(error);
  } catch (const std::exception& e) {
    return std::unexpected(
        internal_error(source.string() + ": reading the configuration failed: " + e.what()));
  }
}

Result<RigConfig> load_config(const fs::path& file, std::vector<std::string>* warnings) {
  std::ifstream stream(file);
  std::error_code ec;
  if (!fs::exists(file, ec))
    return std::unexpected(
        bad_input(file, "", "no such configuration file (see config/rig.example.toml)"));
  if (!stream) return std::unexpected(bad_input(file, "", "cannot open for reading"));
  std::stringstream text;
  text << stream.rdbuf();
  return parse_config(text.str(), fs::absolute(file, ec), warnings);
}

std::vector<std::array<double, 3>> led_positions_mm(const Geometry& geometry) {
  if (!geometry.led_positions_mm.empty()) return geometry.led_positions_mm;
  if (!geometry.led_distance_mm) return {};
  constexpr double kDeg = 3.14159265358979323846 / 180;
  const double d = *geometry.led_distance_mm;
  const double slant = geometry.slant_deg * kDeg;
  std::vector<std::array<double, 3>> positions;
  for (const double tilt_deg : geometry.tilts_deg) {
    const double tilt = tilt_deg * kDeg;
    positions.push_back({d * std::cos(tilt) * std::sin(slant), d * std::sin(tilt) * std::sin(slant),
                         d * std::cos(slant)});
  }
  return positions;
}

}  // namespace psrig::config
