// The gpiod light backend: one GPIO output line per LED, through the C API
// of libgpiod 1.6 (the v1 GPIO character-device uAPI underneath).
//
// Porting to libgpiod 2 (Debian 13 and later) changes the plumbing, not the
// logic:
// - chips open by path only (gpiod_chip_open("/dev/gpiochip0")); names,
//   numbers and labels are resolved by the caller, which find_chip() below
//   already does by scanning /dev and comparing gpiod_chip_info_get_label();
// - gpiod_line, gpiod_line_bulk and gpiod_line_request_config are gone: a
//   request is built from gpiod_line_settings (direction OUTPUT, output
//   value INACTIVE, active_low) added to a gpiod_line_config for our offsets,
//   plus a gpiod_request_config holding the consumer, and made with
//   gpiod_chip_request_lines(), which returns a gpiod_line_request;
// - values are set with gpiod_line_request_set_values() (enum
//   gpiod_line_value, still one ioctl for all lines), released with
//   gpiod_line_request_release();
// - line info comes from gpiod_chip_get_line_info() (gpiod_line_info_is_used,
//   gpiod_line_info_get_consumer) and must be freed;
// - underneath, it speaks the v2 uAPI (GPIO_V2_GET_LINE_IOCTL and friends),
//   so the HIL tests' emulated chip would have to answer those as well.

#include "psrig/lights/gpiod_lights.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <dirent.h>
#include <filesystem>
#include <gpiod.h>
#include <memory>
#include <string>
#include <vector>

#include "psrig/base/log.h"

namespace psrig::lights {
namespace {

constexpr const char* kChipKey = "lights.gpiod.chip";
constexpr const char* kLinesKey = "lights.gpiod.lines";

// The udev rule and group that let the daemon open a GPIO chip.
constexpr const char* kPermissionFix =
    "add the daemon's user to the gpio group (`sudo usermod -aG gpio USER`, then log in again) "
    "and give that group the chips with a udev rule, e.g. /etc/udev/rules.d/60-psrig-gpio.rules: "
    "SUBSYSTEM==\"gpio\", KERNEL==\"gpiochip*\", GROUP=\"gpio\", MODE=\"0660\"";

Error device_error(std::string key, std::filesystem::path node, std::string message) {
  Error error = io_error(std::move(node), std::move(message));
  error.key = std::move(key);
  return error;
}

// A chip the configuration names that is not there (or not a chip): the fix
// is the configuration, so it is bad input (exit 2), not a failing machine.
Error config_error(std::string key, std::filesystem::path node, std::string message) {
  return bad_input(std::move(node), std::move(key), std::move(message));
}

std::string join(const std::vector<unsigned>& values, const char* separator) {
  std::string text;
  for (unsigned value : values)
    text += (text.empty() ? "" : separator) + std::to_string(value);
  return text;
}

// What errno says, with the fix where we know one.
std::string explain_errno(int error, const std::string& node) {
  switch (error) {
    case EACCES:
    case EPERM:
      return std::string("permission denied on ") + node + "; " + kPermissionFix;
    case ENODEV:
    case ENXIO:
      return "the chip vanished (" + std::string(std::strerror(error)) +
             "): it was unplugged or its driver unloaded; LEDs wired to it are no longer under "
             "software control, so check them, reconnect the chip and restart";
    default:
      return std::strerror(error);
  }
}

// Closes a chip we only looked at.
struct ChipCloser {
  void operator()(gpiod_chip* chip) const {
    if (chip) gpiod_chip_close(chip);
  }
};
using ChipPtr = std::unique_ptr<gpiod_chip, ChipCloser>;

unsigned chip_number(const std::string& name) {
  unsigned number = 0;
  for (char c : name.substr(std::strlen("gpiochip")))
    if (c >= '0' && c <= '9') number = number * 10 + static_cast<unsigned>(c - '0');
  return number;
}

std::string describe_chips(const std::vector<GpioChipEntry>& chips) {
  if (chips.empty())
    return "no GPIO chips found in /dev (is the GPIO controller's driver loaded, its device-tree "
           "overlay enabled, the expander plugged in?)";
  std::string text = "chips found: ";
  for (std::size_t i = 0; i < chips.size(); ++i) {
    const auto& chip = chips[i];
    if (i) text += ", ";
    text += chip.name;
    if (chip.open_error)
      text += " (cannot open: " + std::string(std::strerror(chip.open_error)) + ")";
    else
      text += " [" + chip.label + "] " + std::to_string(chip.lines) + " lines";
  }
  return text;
}

// Opens the chip `spec` names: a path (/dev/gpiochip0), a name (gpiochip0),
// a number (0) or a label (pinctrl-bcm2711).
Result<ChipPtr> find_chip(const std::string& spec) {
  if (spec.empty())
    return std::unexpected(bad_input(
        {}, kChipKey, "no GPIO chip given; set it to a name (gpiochip0), a path or a label"));

  std::string path;
  if (spec.front() == '/')
    path = spec;
  else if (std::all_of(spec.begin(), spec.end(), [](char c) { return c >= '0' && c <= '9'; }))
    path = "/dev/gpiochip" + spec;
  else if (spec.rfind("gpiochip", 0) == 0)
    path = "/dev/" + spec;

  if (!path.empty()) {
    if (ChipPtr chip{gpiod_chip_open(path.c_str())}) return chip;
    const int error = errno;
    if (error == EACCES || error == EPERM)
      return std::unexpected(
          device_error(kChipKey, path, "cannot open GPIO chip: " + explain_errno(error, path)));
    if (error == ENOTTY || error == ENODEV)
      return std::unexpected(config_error(kChipKey, path,
                                          "not a GPIO character device; " +
                                              describe_chips(list_gpio_chips()) +
                                              "; `gpiodetect` lists them"));
    if (error != ENOENT)
      return std::unexpected(device_error(
          kChipKey, path, "cannot open GPIO chip: " + std::string(std::strerror(error))));
    return std::unexpected(config_error(
        kChipKey, {},
        "GPIO chip '" + spec + "' not found; " + describe_chips(list_gpio_chips()) +
            "; set lights.gpiod.chip to one of them (name, /dev path or label); `gpiodetect` lists "
            "the chips"));
  }

  // A label: look at every chip.
  const auto chips = list_gpio_chips();
  for (const auto& chip : chips) {
    if (chip.open_error || chip.label != spec) continue;
    if (ChipPtr open{gpiod_chip_open(("/dev/" + chip.name).c_str())}) return open;
  }
  std::string message = "no GPIO chip labelled '" + spec + "'; " + describe_chips(chips);
  // Chips it could not open may hold the label: then the fix is the
  // permissions, not the configuration.
  const bool unopened =
      std::any_of(chips.begin(), chips.end(), [](const GpioChipEntry& c) { return c.open_error; });
  if (unopened) message += "; some could not be opened: " + std::string(kPermissionFix);
  message += "; `gpiodetect` lists the chips and their labels";
  return std::unexpected(unopened ? device_error(kChipKey, {}, message)
                                  : config_error(kChipKey, {}, message));
}

class GpiodLights final : public LightController {
 public:
  GpiodLights(ChipPtr chip, std::vector<unsigned> offsets, bool active_low, gpiod_line_bulk bulk)
      : chip_(std::move(chip)),
        name_(gpiod_chip_name(chip_.get())),
        label_(gpiod_chip_label(chip_.get())),
        offsets_(std::move(offsets)),
        active_low_(active_low),
        bulk_(bulk),
        enabled_(offsets_.size(), true),
        on_(offsets_.size(), false) {
    log_.record(-1, false);  // requested with every line inactive
  }

  ~GpiodLights() override {
    if (auto off = all_off(); !off)
      logger("lights")->error("{}: switching all LEDs off on close failed: {}", describe(),
                              off.error().message);
    gpiod_line_release_bulk(&bulk_);
  }

  GpiodLights(const GpiodLights&) = delete;
  GpiodLights& operator=(const GpiodLights&) = delete;

  int channel_count() const override { return static_cast<int>(offsets_.size()); }

  Status turn_on(int channel) override {
    if (auto checked = check_channel(channel); !checked) return checked;
    // One bulk set is atomic only where the chip driver sets lines together
    // (set_multiple); others set them one by one in our order, so a line
    // still on is switched off by a set of its own first.
    bool others_on = unknown_;
    for (int i = 0; i < channel_count(); ++i)
      others_on = others_on || (on_[i] && i != channel);
    if (others_on) {
      if (auto off = all_off(); !off) return off;
    }
    std::vector<int> values(offsets_.size(), 0);
    values[channel] = enabled_[channel] ? 1 : 0;
    if (auto set = set_values(values, "switching on LED " + std::to_string(channel) + " (line " +
                                          std::to_string(offsets_[channel]) + ")");
        !set)
      return set;
    if (enabled_[channel]) log_.record(channel, true);
    return {};
  }

  Status all_off() override {
    if (auto set = set_values(std::vector<int>(offsets_.size(), 0), "switching all LEDs off"); !set)
      return set;
    log_.record(-1, false);
    return {};
  }

  // GPIO is on or off: 1 is on, 0 disables the channel (turn_on then keeps
  // every LED dark, as a dark frame); anything in between would need PWM,
  // and accepting it silently would put a wrong intensity into scan.json.
  Status set_intensity(int channel, double level) override {
    if (auto checked = check_channel(channel); !checked) return checked;
    if (level != 0.0 && level != 1.0)
      return std::unexpected(bad_input(
          {}, "lights.intensity[" + std::to_string(channel) + "]",
          "gpiod lights are on/off only: intensity " + std::to_string(level) +
              " needs a dimmable driver (the usb or modbus backend); use 1 (on) or 0 (channel "
              "disabled)"));
    enabled_[channel] = level == 1.0;
    return {};
  }

  std::string describe() const override {
    return "gpiod " + name_ + " [" + label_ + "], lines " + join(offsets_, ",") +
           (active_low_ ? ", active low" : "");
  }

 private:
  Status check_channel(int channel) const {
    if (channel < 0 || channel >= channel_count())
      return std::unexpected(internal_error("gpiod lights: no channel " + std::to_string(channel) +
                                            " (" + std::to_string(channel_count()) + " channels)"));
    return {};
  }

  // Logical values (1 = LED on; libgpiod applies active_low), one ioctl.
  Status set_values(const std::vector<int>& values, const std::string& what) {
    if (gpiod_line_set_value_bulk(&bulk_, values.data()) != 0) {
      const int error = errno;
      unknown_ = true;  // the lines may or may not have changed
      return std::unexpected(device_error(kChipKey, "/dev/" + name_,
                                          what + " on " + name_ + " [" + label_ + "] (lines " +
                                              join(offsets_, ",") + ")" +
                                              " failed: " + explain_errno(error, "/dev/" + name_)));
    }
    for (std::size_t i = 0; i < values.size(); ++i)
      on_[i] = values[i] != 0;
    unknown_ = false;
    return {};
  }

  ChipPtr chip_;
  std::string name_, label_;
  std::vector<unsigned> offsets_;
  bool active_low_;
  gpiod_line_bulk bulk_;
  std::vector<bool> enabled_;  // intensity 1 (true) or 0
  std::vector<bool> on_;       // as last set successfully
  bool unknown_ = false;       // a set failed: the lines' state is not known
};

// Why a line cannot be ours, if it cannot.
std::string holder(gpiod_line* line) {
  const char* consumer = gpiod_line_consumer(line);
  return consumer ? "'" + std::string(consumer) + "'" : "the kernel (a driver or device-tree hog)";
}

Error busy_error(const std::string& chip, const std::string& label, unsigned offset,
                 std::size_t channel, gpiod_line* line, const std::string& our_consumer) {
  const char* consumer = gpiod_line_consumer(line);
  std::string fix = consumer && our_consumer == consumer
                        ? "another psrig is running (stop psrigd, or the other `psrig lights`)"
                        : "stop the program or service holding it, or free it in the device tree";
  return device_error(std::string(kLinesKey) + "[" + std::to_string(channel) + "]", "/dev/" + chip,
                      "GPIO line " + std::to_string(offset) + " of " + chip + " [" + label +
                          "] is busy, held by " + holder(line) + "; " + fix +
                          ", or wire the LED to another line (`gpioinfo " + chip +
                          "` shows who holds each line)");
}

}  // namespace

// Every /dev/gpiochipN, in numeric order (opendir rather than
// std::filesystem: umockdev redirects it, which the HIL tests rely on).
std::vector<GpioChipEntry> list_gpio_chips() {
  std::vector<GpioChipEntry> chips;
  DIR* dir = ::opendir("/dev");
  if (!dir) return chips;
  while (const dirent* entry = ::readdir(dir)) {
    const std::string name = entry->d_name;
    if (name.rfind("gpiochip", 0) != 0) continue;
    GpioChipEntry chip{name, {}, 0, 0};
    if (ChipPtr open{gpiod_chip_open(("/dev/" + name).c_str())}) {
      chip.label = gpiod_chip_label(open.get());
      chip.lines = gpiod_chip_num_lines(open.get());
    } else {
      chip.open_error = errno;
    }
    chips.push_back(std::move(chip));
  }
  ::closedir(dir);
  std::sort(chips.begin(), chips.end(), [](const GpioChipEntry& a, const GpioChipEntry& b) {
    return chip_number(a.name) < chip_number(b.name);
  });
  return chips;
}

Result<std::unique_ptr<LightController>> open_gpiod_lights(const config::LightsConfig& config) {
  const auto& gpio = config.gpiod;
  if (gpio.lines.empty())
    return std::unexpected(bad_input(
        {}, kLinesKey, "no GPIO lines; give one line offset per LED, e.g. lines = [17, 27, 22]"));
  if (static_cast<int>(gpio.lines.size()) != config.channels)
    return std::unexpected(bad_input(
        {}, kLinesKey,
        std::to_string(gpio.lines.size()) + " lines for " + std::to_string(config.channels) +
            " channels (lights.channels); give one line offset per LED"));
  if (gpio.lines.size() > GPIOD_LINE_BULK_MAX_LINES)
    return std::unexpected(bad_input(
        {}, kLinesKey, "at most " + std::to_string(GPIOD_LINE_BULK_MAX_LINES) + " lines"));
  for (std::size_t i = 0; i < gpio.lines.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (gpio.lines[i] == gpio.lines[j])
        return std::unexpected(bad_input({}, kLinesKey,
                                         "line " + std::to_string(gpio.lines[i]) +
                                             " given twice (channels " + std::to_string(j) +
                                             " and " + std::to_string(i) + ")"));
  for (std::size_t i = 0; i < config.intensity.size(); ++i) {
    const double level = config.intensity[i];
    if (level != 0.0 && level != 1.0)
      return std::unexpected(bad_input(
          {}, "lights.intensity[" + std::to_string(i) + "]",
          "gpiod lights are on/off only: intensity " + std::to_string(level) +
              " needs a dimmable driver (the usb or modbus backend); use 1 (on) or 0 (disabled)"));
  }

  auto chip = find_chip(gpio.chip);
  if (!chip) return std::unexpected(chip.error());
  gpiod_chip* raw = chip->get();
  const std::string name = gpiod_chip_name(raw);
  const std::string label = gpiod_chip_label(raw);
  const unsigned count = gpiod_chip_num_lines(raw);

  gpiod_line_bulk bulk;
  gpiod_line_bulk_init(&bulk);
  for (std::size_t i = 0; i < gpio.lines.size(); ++i) {
    const unsigned offset = gpio.lines[i];
    const std::string key = std::string(kLinesKey) + "[" + std::to_string(i) + "]";
    if (offset >= count)
      return std::unexpected(
          bad_input({}, key,
                    "line " + std::to_string(offset) + " does not exist: " + name + " [" + label +
                        "] has " + std::to_string(count) + " lines (0 to " +
                        std::to_string(count - 1) + "); `gpioinfo " + name + "` lists them"));
    gpiod_line* line = gpiod_chip_get_line(raw, offset);  // reads the line's info
    if (!line)
      return std::unexpected(device_error(key, "/dev/" + name,
                                          "cannot read line " + std::to_string(offset) + " of " +
                                              name + " [" + label +
                                              "]: " + explain_errno(errno, "/dev/" + name)));
    if (gpiod_line_is_used(line))
      return std::unexpected(busy_error(name, label, offset, i, line, gpio.consumer));
    gpiod_line_bulk_add(&bulk, line);
  }

  gpiod_line_request_config request{};
  request.consumer = gpio.consumer.c_str();
  request.request_type = GPIOD_LINE_REQUEST_DIRECTION_OUTPUT;
  request.flags = gpio.active_low ? GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW : 0;
  const std::vector<int> inactive(gpio.lines.size(), 0);
  if (gpiod_line_request_bulk(&bulk, &request, inactive.data()) != 0) {
    const int error = errno;
    if (error == EBUSY) {
      // Taken between our look and our request: say by whom.
      for (std::size_t i = 0; i < gpio.lines.size(); ++i) {
        gpiod_line* line = gpiod_line_bulk_get_line(&bulk, static_cast<unsigned>(i));
        if (gpiod_line_update(line) == 0 && gpiod_line_is_used(line))
          return std::unexpected(busy_error(name, label, gpio.lines[i], i, line, gpio.consumer));
      }
    }
    return std::unexpected(
        device_error(kLinesKey, "/dev/" + name,
                     "cannot request lines " + join(gpio.lines, ",") + " of " + name + " [" +
                         label + "] as outputs: " + explain_errno(error, "/dev/" + name)));
  }

  auto lights = std::make_unique<GpiodLights>(std::move(*chip), gpio.lines, gpio.active_low, bulk);
  for (std::size_t i = 0; i < config.intensity.size() && i < gpio.lines.size(); ++i)
    (void)lights->set_intensity(static_cast<int>(i), config.intensity[i]);
  return lights;
}

}  // namespace psrig::lights
