// psrigd and `psrig status` say which calibration the rig has and whether
// it is missing or older than [calibration] max_age_days.

#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "daemon_process.h"
#include "psrig/calibration/calibration_store.h"
#include "psrig/calibration/light_calibration.h"
#include "psrig/formats/light_matrix.h"
#include "psrig/lights/switch_log.h"
#include "psrig/lights/switch_log_file.h"

namespace psrig::test {
namespace {

// A calibration version as the store keeps it, made `created`.
void store_calibration(const fs::path& scans, const std::string& version,
                       const std::string& created) {
  const fs::path directory = scans / "calibrations" / version;
  fs::create_directories(directory);
  json per_light = json::array();
  for (int k = 0; k < 3; ++k)
    per_light.push_back({{"index", k}, {"direction", {0.5, 0.0, 0.8}}, {"intensity", 1.0}});
  std::ofstream(directory / "calibration.json") << json{
      {"format", "psrig-calibration/1"},
      {"created", created},
      {"contains", {"lights"}},
      {"lights", {{"method", "chrome"}, {"per_light", per_light}}},
      {"flat", nullptr},
      {"colour", nullptr},
      {"scale", nullptr},
      {"led_positions_mm", nullptr}}.dump(2);
}

TEST(PsrigdCalibration, StatusSaysMissingCurrentAndStale) {
  TempDir temp;
  const int port = free_port();
  Daemon daemon(
      daemon_config(temp, port, {{"[storage]", "[calibration]\nmax_age_days = 30\n\n[storage]"}}),
      port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();

  auto status = daemon.get("/v1/status")["calibration"];
  EXPECT_TRUE(status["missing"].get<bool>()) << status.dump();
  EXPECT_FALSE(status["stale"].get<bool>());
  EXPECT_TRUE(status["version"].is_null());
  auto text = run_program("psrig", {"status", "--url", daemon.url()});
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_TRUE(contains(text.out, "calibration: missing")) << text.out;

  store_calibration(temp / "scans", "0001", calibration::utc_now());
  status = daemon.get("/v1/status")["calibration"];
  EXPECT_FALSE(status["missing"].get<bool>()) << status.dump();
  EXPECT_FALSE(status["stale"].get<bool>());
  EXPECT_EQ(status["version"], "0001");
  EXPECT_EQ(status["sections"], json::array({"lights"}));
  EXPECT_LT(status["age_days"].get<double>(), 0.1);
  EXPECT_EQ(status["max_age_days"], 30);

  store_calibration(temp / "scans", "0002", "2020-01-01T00:00:00Z");
  status = daemon.get("/v1/status")["calibration"];
  EXPECT_EQ(status["version"], "0002");
  EXPECT_TRUE(status["stale"].get<bool>()) << status.dump();
  EXPECT_GT(status["age_days"].get<double>(), 365);
  text = run_program("psrig", {"status", "--url", daemon.url()});
  EXPECT_TRUE(contains(text.out, "calibration: 0002 (lights)")) << text.out;
  EXPECT_TRUE(contains(text.out, "STALE")) << text.out;
  auto as_json = run_program("psrig", {"status", "--url", daemon.url(), "--json"});
  EXPECT_TRUE(json::parse(as_json.out)["calibration"]["stale"].get<bool>()) << as_json.out;
}

TEST(PsrigdCalibration, ScanAndConfigCheckSayWhenACalibrationIsStale) {
  TempDir temp;
  const fs::path config = daemon_config(temp, free_port());
  store_calibration(temp / "scans", "0001", "2020-01-01T00:00:00Z");
  auto check = run_program("psrig", {"config", "check", config.string()});
  ASSERT_EQ(check.exit_code, 0) << check.err;
  EXPECT_TRUE(contains(check.out, "calibration 0001")) << check.out;
  EXPECT_TRUE(contains(check.out, "stale")) << check.out;
  auto scan = run_program("psrig", {"scan", "--config", config.string(), "--no-process"});
  ASSERT_EQ(scan.exit_code, 0) << scan.err;
  EXPECT_TRUE(contains(scan.err, "psrig scan: warning: the rig's calibration 0001 is")) << scan.err;
  EXPECT_TRUE(contains(scan.err, "max_age_days = 30")) << scan.err;

  // 0: never stale.
  std::ofstream(config, std::ios::app) << "\n[calibration]\nmax_age_days = 0\n";
  scan = run_program("psrig", {"scan", "--config", config.string(), "--no-process"});
  ASSERT_EQ(scan.exit_code, 0) << scan.err;
  EXPECT_FALSE(contains(scan.err, "warning")) << scan.err;

  std::ofstream(temp / "bad.toml") << "[calibration]\nmax_age_days = -3\n";
  auto bad = run_program("psrig", {"config", "check", (temp / "bad.toml").string()});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_TRUE(contains(bad.err, "calibration.max_age_days")) << bad.err;
}

std::pair<int, json> post(Daemon& daemon, const json& body) {
  auto res = daemon.http().Post("/v1/calibrations", body.dump(), "application/json");
  EXPECT_TRUE(res);
  if (!res) return {0, nullptr};
  return {res->status, json::parse(res->body, nullptr, false)};
}

// The job `id` once it has ended (or whatever it is after `limit`).
json wait_calibration(Daemon& daemon, std::int64_t id, std::chrono::seconds limit = 90s) {
  const auto until = std::chrono::steady_clock::now() + limit;
  json job;
  while (std::chrono::steady_clock::now() < until) {
    const json listed = daemon.get("/v1/calibrations");
    for (const auto& j : listed["jobs"])
      if (j["id"] == id) job = j;
    if (job.is_object() && job["status"] != "queued" && job["status"] != "running") return job;
    std::this_thread::sleep_for(50ms);
  }
  ADD_FAILURE() << "calibration " << id << " still " << job.dump();
  return job;
}

// psrigd runs the rig's calibrations through its API, queued with the scans.
TEST(PsrigdCalibration, CalibrationsRunThroughTheApiQueuedWithScans) {
  TempDir temp;
  const int port = free_port();
  const fs::path switches = temp / "switches.log";
  // A sphere under the camera (a scan still runs): the ChArUco board cannot
  // be found there, so the scale calibration fails.
  const auto config =
      daemon_config(temp, port,
                    {{"width = 160", "width = 640"},
                     {"height = 120", "height = 480"},
                     {"target = \"swatch\"", "target = \"chrome_sphere\""},
                     {"max_on_ms = 5000", "max_on_ms = 5000\n\n[lights.sim]\nswitch_log = \"" +
                                              switches.string() + "\""}});
  Daemon daemon(config, port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  EXPECT_TRUE(daemon.get("/v1/status")["calibration"]["missing"].get<bool>());
  daemon.get("/v1/calibrations/current", 404);

  auto [status, queued] = post(daemon, {{"kind", "lights"}, {"frames", 1}});
  ASSERT_EQ(status, 202) << queued.dump();
  auto job = wait_calibration(daemon, queued["id"].get<std::int64_t>());
  ASSERT_EQ(job["status"], "done") << job.dump() << daemon.log();
  EXPECT_EQ(job["version"], "0001");
  auto calibration = daemon.get("/v1/status")["calibration"];
  EXPECT_FALSE(calibration["missing"].get<bool>()) << calibration.dump();
  EXPECT_FALSE(calibration["stale"].get<bool>());
  EXPECT_EQ(calibration["version"], "0001");
  EXPECT_EQ(calibration["sections"], json::array({"lights"}));
  const auto current = daemon.get("/v1/calibrations/current");
  ASSERT_EQ(current["calibration"]["lights"]["per_light"].size(), 3u) << current.dump();
  for (int k = 0; k < 3; ++k) {
    const auto& d = current["calibration"]["lights"]["per_light"][k]["direction"];
    const cv::Vec3d found(d[0].get<double>(), d[1].get<double>(), d[2].get<double>());
    EXPECT_LT(calibration::angle_deg(found, formats::light_direction(120.0 * k, 45)), 0.3) << k;
  }
  EXPECT_EQ(daemon.get("/v1/calibrations")["versions"].size(), 1u);

  // Queued behind a scan: it starts once the scan has ended.
  const auto scan = daemon.submit({{"sample_id", "before-calibration"}});
  auto [behind_status, behind] = post(daemon, {{"kind", "lights"}, {"frames", 1}});
  ASSERT_EQ(behind_status, 202) << behind.dump();
  EXPECT_EQ(daemon.wait_finished(scan)["status"], "done");
  job = wait_calibration(daemon, behind["id"].get<std::int64_t>());
  EXPECT_EQ(job["status"], "done") << job.dump();
  EXPECT_GE(job["scans_finished_before"].get<int>(), 1) << job.dump();
  EXPECT_EQ(job["version"], "0002");

  // A calibration that fails: an error event's message in its job, the
  // LEDs off, and psrigd still serving.
  auto [failing_status, failing] = post(daemon, {{"kind", "scale"}});
  ASSERT_EQ(failing_status, 202) << failing.dump();
  job = wait_calibration(daemon, failing["id"].get<std::int64_t>());
  EXPECT_EQ(job["status"], "failed") << job.dump();
  EXPECT_TRUE(contains(job["error"].get<std::string>(), "board")) << job.dump();
  {
    // Its error event, replayed from the start of the stream.
    std::string stream;
    httplib::Client listener("127.0.0.1", port);
    listener.set_read_timeout(10s);
    (void)listener.Get("/v1/events", httplib::Headers{{"Last-Event-ID", "0"}},
                       [&](const char* data, std::size_t length) {
                         stream.append(data, length);
                         return !contains(stream, "event: error");
                       });
    const auto error = stream.find("event: error");
    ASSERT_NE(error, std::string::npos) << stream;
    const auto data = stream.find("data: ", error);
    const auto event = json::parse(stream.substr(data + 6, stream.find('\n', data) - data - 6));
    EXPECT_EQ(event["calibration"], failing["id"]) << event.dump();
    EXPECT_EQ(event["kind"], "scale");
    EXPECT_TRUE(contains(event["error"].get<std::string>(), "board")) << event.dump();
  }
  auto logged = lights::read_switch_log_file(switches);
  ASSERT_TRUE(logged) << logged.error().describe();
  lights::SwitchLog log;
  lights::replay(*logged, log);
  EXPECT_TRUE(log.on_now().empty());
  EXPECT_EQ(daemon.get("/v1/calibrations")["versions"].size(), 2u);  // nothing stored
  EXPECT_NE(daemon.get("/v1/status")["state"], "error");
  const auto after = daemon.submit({{"sample_id", "after-failure"}});
  EXPECT_EQ(daemon.wait_finished(after)["status"], "done") << daemon.log();

  // Kinds it does not run, and options it does not know.
  auto [unknown_status, unknown] = post(daemon, {{"kind", "teapot"}});
  EXPECT_EQ(unknown_status, 400);
  EXPECT_TRUE(contains(unknown["error"].get<std::string>(), "not supported")) << unknown.dump();
  auto [bad_status, bad] = post(daemon, {{"kind", "lights"}, {"frames", 0}});
  EXPECT_EQ(bad_status, 400) << bad.dump();
  auto [field_status, field] = post(daemon, {{"kind", "flat"}, {"target", "chrome"}});
  EXPECT_EQ(field_status, 400) << field.dump();
  EXPECT_TRUE(contains(field["error"].get<std::string>(), "target: unknown field")) << field.dump();
}

// The colour calibration through the API: the simulated ColorChecker under
// a camera that mixes its channels (a known answer), stored as the new
// version's colour section, listed in the status, applied to later scans.
TEST(PsrigdCalibration, ColourRunsThroughTheApi) {
  TempDir temp;
  const int port = free_port();
  // Rows: the camera's R, G, B from the scene's linear sRGB; the target
  // stays the swatch (each calibration puts its own under the camera).
  const cv::Matx33d mixing(0.62, 0.30, 0.08, 0.12, 0.80, 0.08, 0.03, 0.27, 0.55);
  const auto config = daemon_config(
      temp, port,
      {{"width = 160", "width = 640"},
       {"height = 120", "height = 480"},
       {"[sim]\n",
        "[sim]\ncolour_matrix = [0.62, 0.30, 0.08, 0.12, 0.80, 0.08, 0.03, 0.27, 0.55]\n"}});
  Daemon daemon(config, port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();

  // Before the lights: refused, nothing stored.
  auto [early_status, early] = post(daemon, {{"kind", "colour"}});
  ASSERT_EQ(early_status, 202) << early.dump();
  auto job = wait_calibration(daemon, early["id"].get<std::int64_t>());
  EXPECT_EQ(job["status"], "failed") << job.dump();
  EXPECT_TRUE(contains(job["error"].get<std::string>(), "psrig calibrate lights first"))
      << job.dump();
  EXPECT_TRUE(daemon.get("/v1/status")["calibration"]["missing"].get<bool>());

  auto [lights_status, lights] = post(daemon, {{"kind", "lights"}, {"frames", 1}});
  ASSERT_EQ(lights_status, 202) << lights.dump();
  ASSERT_EQ(wait_calibration(daemon, lights["id"].get<std::int64_t>())["status"], "done")
      << daemon.log();
  auto [status, queued] = post(daemon, {{"kind", "colour"}, {"frames", 2}});
  ASSERT_EQ(status, 202) << queued.dump();
  EXPECT_EQ(queued["kind"], "colour");
  job = wait_calibration(daemon, queued["id"].get<std::int64_t>(), 180s);
  ASSERT_EQ(job["status"], "done") << job.dump() << daemon.log();
  EXPECT_EQ(job["version"], "0002");

  const auto calibration = daemon.get("/v1/status")["calibration"];
  EXPECT_EQ(calibration["version"], "0002");
  EXPECT_EQ(calibration["sections"], json::array({"lights", "colour"})) << calibration.dump();
  const json colour = daemon.get("/v1/calibrations/current")["calibration"]["colour"];
  ASSERT_TRUE(colour.is_object()) << colour.dump();
  EXPECT_EQ(colour["space"], "sRGB D65");
  EXPECT_EQ(colour["sources"]["captures"].size(), 2u) << colour["sources"].dump();
  EXPECT_LE(colour["delta_e2000"]["after"]["mean"].get<double>(), 1.0) << colour.dump();
  EXPECT_GE(colour["delta_e2000"]["before"]["mean"].get<double>(), 5.0) << colour.dump();
  // The matrix undoes the camera's mixing, up to the exposure's scale.
  cv::Matx33d matrix;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      matrix(r, c) = colour["matrix"][r][c].get<double>();
  const cv::Matx33d product = matrix * mixing;
  const double scale = (product(0, 0) + product(1, 1) + product(2, 2)) / 3;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(product(r, c) / scale, r == c ? 1.0 : 0.0, 0.02) << r << "," << c;

  // Later scans carry it: their albedo is sRGB D65.
  const auto scan = daemon.wait_finished(daemon.submit({{"sample_id", "coloured"}}));
  ASSERT_EQ(scan["status"], "done") << scan.dump() << daemon.log();
  EXPECT_EQ(scan["report"]["albedo_colour_space"], "sRGB D65") << scan["report"].dump();
  EXPECT_EQ(scan["report"]["colour_calibration"], "0002");

  // Files on this machine are not the API's: no --image over HTTP.
  auto [image_status, image] = post(daemon, {{"kind", "colour"}, {"image", "/tmp/chart.png"}});
  EXPECT_EQ(image_status, 400) << image.dump();
  EXPECT_TRUE(contains(image["error"].get<std::string>(), "image: unknown field")) << image.dump();
}

// [processing] reject reaches psrigd's scans too.
TEST(PsrigdCalibration, ScansUseRejectFromRigToml) {
  TempDir temp;
  const int port = free_port();
  const auto config = daemon_config(temp, port,
                                    {{"tilts_deg = [0, 120, 240]", "tilts_deg = [0, 90, 180, 270]"},
                                     {"channels = 3", "channels = 4"},
                                     {"[storage]", "[processing]\nreject = true\n\n[storage]"}});
  Daemon daemon(config, port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  const auto entry = daemon.wait_finished(daemon.submit({{"sample_id", "robust"}}));
  ASSERT_EQ(entry["status"], "done") << entry.dump() << daemon.log();
  EXPECT_TRUE(entry["report"]["options"]["reject_outliers"].get<bool>()) << entry["report"].dump();
  EXPECT_EQ(entry["report"]["options"]["reject_method"], "lts-reweighted");
}

}  // namespace
}  // namespace psrig::test
