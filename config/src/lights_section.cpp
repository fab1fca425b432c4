// rig.toml's [lights] and each backend's table under it ([lights.gpiod],
// [lights.usb], [lights.modbus], [lights.sim]), and the lights against [geometry].

#include <string>

#include "section_readers.h"
#include "toml_section.h"

namespace psrig::config {

Status read_lights(Section& lights, RigConfig& c) {
  const fs::path& section_file = lights.file();
  PSRIG_TRY(lights.get("backend", c.lights.backend, {"gpiod", "usb", "modbus", "sim"}));
  PSRIG_TRY(lights.get("channels", c.lights.channels, 3, 16));
  PSRIG_TRY(lights.get("intensity", c.lights.intensity, 0, 1));
  PSRIG_TRY(lights.get("max_on_ms", c.lights.max_on_ms, 1, 600000));
  {
    auto gpiod = lights.sub("gpiod");
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

    auto usb = lights.sub("usb");
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

    auto modbus = lights.sub("modbus");
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
      auto registers = modbus->sub("registers");
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

    auto sim_lights = lights.sub("sim");
    if (!sim_lights) return std::unexpected(sim_lights.error());
    std::string switch_log;
    PSRIG_TRY(sim_lights->get("switch_log", switch_log));
    // Relative to the configuration file, as storage.root is.
    if (!switch_log.empty()) c.lights.sim.switch_log = relative_to_file(section_file, switch_log);
    sim_lights->finish();
  }
  lights.finish();
  return {};
}

Status check_lights_against_geometry(const Section& lights, const Section& geometry, RigConfig& c) {
  if (!c.lights.intensity.empty() &&
      c.lights.intensity.size() != static_cast<std::size_t>(c.lights.channels))
    return std::unexpected(lights.error_at(lights.find("intensity"), "intensity",
                                           "gives " + std::to_string(c.lights.intensity.size()) +
                                               " values for " + std::to_string(c.lights.channels) +
                                               " channels"));
  if (geometry.find("tilts_deg") &&
      c.geometry.tilts_deg.size() != static_cast<std::size_t>(c.lights.channels))
    return std::unexpected(
        geometry.error_at(geometry.find("tilts_deg"), "tilts_deg",
                          "gives " + std::to_string(c.geometry.tilts_deg.size()) + " tilts for " +
                              std::to_string(c.lights.channels) + " lights (lights.channels)"));
  if (geometry.find("led_positions_mm") &&
      c.geometry.led_positions_mm.size() != static_cast<std::size_t>(c.lights.channels))
    return std::unexpected(geometry.error_at(
        geometry.find("led_positions_mm"), "led_positions_mm",
        "gives " + std::to_string(c.geometry.led_positions_mm.size()) + " positions for " +
            std::to_string(c.lights.channels) + " lights (lights.channels)"));
  if (!geometry.find("tilts_deg") && c.lights.channels != 3) {
    c.geometry.tilts_deg.clear();  // evenly spread, one per channel
    for (int k = 0; k < c.lights.channels; ++k)
      c.geometry.tilts_deg.push_back(360.0 * k / c.lights.channels);
  }
  return {};
}

}  // namespace psrig::config
