#pragma once
// The rig configuration (rig.toml): what psrig knows about the hardware it
// drives. Every field has a default; config/rig.example.toml documents them
// for a real rig, config/sim.toml for the simulated one.

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace psrig::config {

// Where the lights are, docs/design.md "Axes and units": tilt from +x toward +y, slant from +z.
struct Geometry {
  double slant_deg = 45;
  std::vector<double> tilts_deg = {0, 120, 240};  // one per light, in channel order
  double working_distance_mm = 200;               // camera to swatch
  std::optional<double> pixel_size_mm;            // on the swatch; absent: heights in pixels
  // Near-field LEDs: each LED's position in millimetres, camera axes, origin
  // where the camera axis meets the swatch plane (x right, y up, z toward
  // the camera). Either given one per light, or placed by led_distance_mm
  // (distance from the origin) along each light's slant and tilt. Neither:
  // the LEDs are distant (a direction each, the same over the field).
  std::vector<std::array<double, 3>> led_positions_mm;
  std::optional<double> led_distance_mm;
  // The swatch's top above the reference plane the LED positions are
  // measured from (a thick swatch, a raised bed): near-field scans place
  // the LEDs that much lower relative to the swatch (scan.json's position_mm).
  double swatch_height_mm = 0;

  bool operator==(const Geometry&) const = default;
};

// Each LED's position in mm (led_positions_mm, or led_distance_mm along
// slant and tilt), or an empty vector when the LEDs are distant.
[[nodiscard]] std::vector<std::array<double, 3>> led_positions_mm(const Geometry& geometry);

// A GPIO line per LED, through libgpiod.
struct GpiodLights {
  std::string chip = "gpiochip0";  // name, path (/dev/gpiochip0) or label
  std::vector<unsigned> lines;     // offsets, one per channel
  bool active_low = false;         // LED on when the line is driven low
  std::string consumer = "psrig";
};

// The rig's USB strobe controller (lights/PROTOCOL.md).
struct UsbLights {
  std::uint16_t vendor_id = 0x1209;
  std::uint16_t product_id = 0x5053;
  std::string serial;      // empty: the only controller present
  int timeout_ms = 500;    // per USB transfer
  int watchdog_ms = 1000;  // the controller turns everything off without a heartbeat
};

// Registers of a Modbus LED driver; defaults documented in rig.example.toml.
struct ModbusRegisters {
  int enable_coil = 0;           // coils enable_coil + channel: LED on/off
  int all_off_coil = 32;         // coil: writing 1 turns every LED off (-1: clear the enable coils)
  int intensity_register = 100;  // holding registers intensity_register + channel
  int intensity_full_scale = 1000;
  int status_register = 0;  // input register: nonzero = driver fault
  int id_register = 1;      // input registers: device id, then firmware version (-1: none)
  int device_id = 0x4C44;   // what id_register must read, checked at open ("LD")
};

// A Modbus LED driver over RTU (serial) or TCP, through libmodbus.
struct ModbusLights {
  std::string transport = "tcp";  // "tcp" | "rtu"
  std::string device = "/dev/ttyUSB0";
  int baud = 19200;
  char parity = 'N';  // 'N' | 'E' | 'O'
  int data_bits = 8;
  int stop_bits = 1;
  std::string host = "127.0.0.1";
  int port = 502;
  int slave = 1;
  int timeout_ms = 300;
  int retries = 2;
  ModbusRegisters registers;
};

// The simulated rig's LEDs (backend "sim").
struct SimLights {
  // Every switch appended to this file, one line each
  // (lights/switch_log_file.h), for tests to read from outside the
  // process; relative to the configuration file. Empty: none.
  std::filesystem::path switch_log;
};

struct LightsConfig {
  std::string backend = "sim";  // "gpiod" | "usb" | "modbus" | "sim"
  int channels = 3;
  std::vector<double> intensity;  // per channel, 0..1; empty: all 1
  int max_on_ms = 5000;           // safety: an LED left on longer is turned off
  GpiodLights gpiod;
  UsbLights usb;
  ModbusLights modbus;
  SimLights sim;
};

struct CameraConfig {
  std::string backend = "sim";         // "v4l2" | "libcamera" | "sim"
  std::string device = "/dev/video0";  // v4l2 device node, or libcamera camera id ("" = first)
  std::string format = "auto";  // v4l2 fourcc (GREY, Y16, YUYV, RGB3, BGR3, BA81, ...) or "auto"
  int width = 0;                // 0: the camera's (or the simulator's) default
  int height = 0;
  int exposure_us = 20000;
  double gain = 1.0;
  int frames_average = 2;  // frames averaged per light
  int frames_discard = 1;  // frames thrown away after each switch, on top of the stale-frame rule
  int timeout_ms = 2000;   // per frame
  // Where the camera axis meets the image, pixels (x right, y down);
  // absent: the image centre, ((w - 1)/2, (h - 1)/2). Near-field scans and
  // the LEDs' positions are measured from it.
  std::optional<std::array<double, 2>> principal_point_px;
};

struct CaptureConfig {
  bool dark_frame = true;  // capture a frame with every LED off
  int settle_ms = 10;      // after an LED turns on, before an exposure may start
  bool process = true;     // process the scan into maps after capturing it
};

// [processing]: how psrig scan and psrigd process every scan.
struct ProcessingConfig {
  // Robust rejection (processing's --reject): shadows, saturation and
  // unsaturated highlights left out of each pixel's solve.
  bool reject = false;
};

// [calibration]: the rig's calibration procedures and how old one may get.
struct CalibrationConfig {
  // A calibration older than this many days is stale (psrig scan warns,
  // psrig status and psrigd's status say so); 0: never stale.
  int max_age_days = 30;
  // The chrome sphere's diameter, mm, for the LEDs' positions (psrig
  // calibrate lights --places; --sphere-mm overrides); absent: the
  // simulated sphere's on the simulated rig.
  std::optional<double> sphere_diameter_mm;
};

struct StorageConfig {
  // This rig's storage: its scans and its calibration store. With a shared
  // catalogue (CatalogueConfig) it is shared_root/<daemon.rig_name>, each
  // rig under its own prefix of the lab's shared storage; else shared_root.
  std::filesystem::path root = "/var/lib/psrig/scans";
  // storage.root as rig.toml gives it: what every catalogue row's paths are
  // relative to, the same directory on every rig (an NFS or SMB mount).
  std::filesystem::path shared_root = "/var/lib/psrig/scans";
  // Lossless compression of what a scan writes: the EXR maps ("auto",
  // "zip", "piz" or "none"; processing's storage_options.h says what auto
  // does) and the PNG frames and maps (deflate 0 stored … 9).
  std::string exr_compression = "auto";
  int png_level = 1;
  // p, q and height.exr as "half" or 32-bit "float" floats (processing's
  // storage_options.h says why half is the default).
  std::string map_precision = "half";
};

// The simulated world: the swatch, the simulated camera, its timing.
struct SimConfig {
  // What lies under the camera: the swatch, or a calibration target (a
  // chrome or a matte sphere resting on black velvet in the field's centre,
  // or a flat white card filling the field, or a ChArUco board printed on it:
  // sim/card_target.h). rig.toml's "flat" is read as "white_card" with
  // card_albedo 0.6 (a flat matte grey card; the name older configs use).
  std::string target = "swatch";  // "swatch" | "chrome_sphere" | "matte_sphere" |
                                  // "white_card" | "charuco_board" | "colour_chart"
  double card_albedo = 0.75;      // the white card's albedo (0.6: a grey card)
  double sphere_diameter_mm = 10;
  // Where the sphere rests: its centre in mm from the camera axis (x right,
  // y up); absent: the field's centre. Placing it at two or more places
  // lets calibration find near LEDs' positions.
  std::optional<std::array<double, 2>> sphere_centre_mm;
  // The places psrig calibrate lights --places moves the sphere to, in
  // order (mm from the camera axis); empty: spread round the field.
  std::vector<std::array<double, 2>> sphere_places_mm;
  // The simulated LEDs' true distance (mm, along the geometry's slant and
  // tilts) when [geometry] gives no positions: a near-field rig whose
  // geometry nobody measured, for calibration to find.
  std::optional<double> led_distance_mm;
  // The camera's colour response: row by row, the 3x3 matrix from the
  // scene's linear sRGB to the camera's RGB. Absent: identity (the camera
  // sees sRGB). A real sensor mixes its channels; psrig calibrate colour
  // finds the inverse from a ColorChecker ("colour_chart").
  std::optional<std::array<double, 9>> colour_matrix;
  double led_angular_diameter_deg = 2;  // each LED as the sphere sees it (chrome highlight size)
  // The swatch: a .chart or .weave file (config/patterns/README.md; made
  // absolute from the rig.toml's folder) or a shipped pattern's name
  // (stockinette, garter, rib-1x1, rib-2x2, seed, basketweave, stripes,
  // plain, twill-2x2, satin-5; jersey, rib and twill are the older names of
  // stockinette, rib-1x1 and twill-2x2), found in patterns_dir.
  std::string pattern = "jersey";
  // Where the shipped patterns are; empty: <psrig's folder>/../share/psrig/
  // patterns when installed, else the source tree's config/patterns.
  std::filesystem::path patterns_dir;
  double swatch_rotation_deg = 0;  // the fabric turned counterclockwise (as seen) on the rig
  std::uint64_t seed = 1;
  int width = 640;
  int height = 480;
  double pixel_size_mm = 0.025;
  int bit_depth = 12;        // sensor ADC bits; frames are delivered in 16-bit containers
  double full_well = 10000;  // electrons at full scale: sets the shot noise
  double read_noise = 3;     // electrons RMS
  double black_level = 64;   // in the ADC's codes
  double ambient = 0.002;    // room light, fraction of an LED's irradiance
  double vignetting = 0.15;  // fractional fall-off at the image corners
  // A white facet facing the LED, as a fraction of full scale (gain 1, 20 ms).
  double led_irradiance = 1.5;
  int readout_us = 15000;     // sensor readout after each exposure
  int frame_interval_us = 0;  // 0: exposure + readout

  bool operator==(const SimConfig&) const = default;
};

// [catalogue]: where psrigd records its scans.
struct CatalogueConfig {
  // Empty or "sqlite": the embedded SQLite file in storage.root, this rig's
  // alone (the default). "postgresql://…" (or "postgres://…", libpq's URI):
  // one PostgreSQL database that every rig of a lab writes to and every
  // psrigd reads.
  std::string url;
  // PostgreSQL only: the file on this machine that keeps the row writes
  // the database could not take (an outage) until it is back; empty:
  // storage.root/catalogue-journal.json.
  std::filesystem::path journal;

  bool operator==(const CatalogueConfig&) const = default;
};

// Whether the catalogue is the lab's shared PostgreSQL database.
[[nodiscard]] bool is_shared_catalogue(const CatalogueConfig& catalogue);

// psrigd, the rig's daemon: where its HTTP API listens, who may use it, how
// many scans may wait, and its Modbus TCP server for a PLC. The systemd
// watchdog interval comes from the unit (WatchdogSec=), not from here.
struct DaemonConfig {
  std::string listen_address = "127.0.0.1";  // the HTTP API's address
  int port = 8470;
  // Bearer token the HTTP API requires when set; required (16 characters
  // or more) when listen_address is not a loopback address.
  std::string token;
  int queue_limit = 16;                      // scans waiting, not counting the running one
  std::string modbus_address = "127.0.0.1";  // the PLC's Modbus TCP server
  int modbus_port = 0;                       // 0: no Modbus server
  // IPv4 addresses of the PLCs that may connect to it; empty: anyone who
  // can reach modbus_address (Modbus has no authentication).
  std::vector<std::string> modbus_allow;
  // The web catalogue's built files (web/ → build/web); empty: found beside
  // psrigd (../web in the build tree, ../share/psrig/web when installed).
  std::filesystem::path web_root;
  // This rig's name in every catalogue row it writes, in the rigs list and
  // (with a shared catalogue) its storage prefix; default: the hostname.
  std::string rig_name;
  // "rig": runs the rig's scans; "catalogue": no rig, serves the catalogue
  // and the API over every rig's scans and forwards scans to the rigs.
  std::string role = "rig";
  // Where other psrigd reach this one's API (written to the shared
  // catalogue's rigs list); default: http://<listen address or hostname>:<port>.
  std::string public_url;
};

// This machine's name (gethostname), empty when it has none: the default
// daemon.rig_name.
[[nodiscard]] std::string host_name();

// A loopback address (127.0.0.0/8, ::1, "localhost"): only this machine can connect.
[[nodiscard]] bool is_loopback_address(const std::string& address);

struct RigConfig {
  std::filesystem::path source;  // the file it came from, for messages
  Geometry geometry;
  LightsConfig lights;
  CameraConfig camera;
  CaptureConfig capture;
  StorageConfig storage;
  ProcessingConfig processing;
  CalibrationConfig calibration;
  SimConfig sim;
  DaemonConfig daemon;
  CatalogueConfig catalogue;
};

}  // namespace psrig::config
