// The `psrig` program as a technician meets it: exit codes, messages, and
// nothing half-written.

#include <chrono>
#include <cmath>
#include <fcntl.h>
#include <fstream>
#include <functional>
#include <iterator>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "psrig/formats/image_io.h"
#include "psrig/formats/map_encoding.h"
#include "sim_modbus_driver.h"
#include "synthetic_scene.h"
#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;

TEST(PsrigCli, SynthThenProcess) {
  TempDir temp;
  const auto scan = (temp / "scan").string();
  auto synth = run_program("psrig", {"synth", "--out", scan, "--pattern", "rib", "--size",
                                     "160x120", "--noise", "0.002"});
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  auto process = run_program("psrig", {"process", scan, "--threads", "2"});
  ASSERT_EQ(process.exit_code, 0) << process.err;
  EXPECT_TRUE(contains(process.out, "maps: " + scan + "/maps")) << process.out;
  EXPECT_TRUE(contains(process.out, "ground truth: mean angular error")) << process.out;
  EXPECT_FALSE(contains(process.out, "outside mask")) << process.out;  // no mask, none outside
  EXPECT_TRUE(fs::exists(temp / "scan" / "maps" / "normal.png"));
}

TEST(PsrigCli, RejectWithThreeLightsWarnsThatItDoesNothing) {
  TempDir temp;
  const auto scan = (temp / "scan").string();
  ASSERT_EQ(run_program("psrig", {"synth", "--out", scan, "--size", "32x24"}).exit_code, 0);
  auto run = run_program("psrig", {"process", scan, "--reject", "--quiet"});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(contains(run.err, "warning: --reject needs four or more lights; this scan has 3"))
      << run.err;
  auto without = run_program("psrig", {"process", scan, "--quiet"});
  EXPECT_EQ(without.exit_code, 0) << without.err;
  EXPECT_TRUE(without.err.empty()) << without.err;
}

// Twelve glossy lights written as a scan directory by hand: --reject runs
// the robust fit without a warning, and report.json names it.
TEST(PsrigCli, RejectWithTwelveLightsNamesTheMethodInTheReport) {
  TempDir temp;
  const fs::path scan = temp / "scan";
  fs::create_directories(scan);
  const auto lights = dome_lights(12, 50);
  const formats::Scan rendered = render_scan(sphere_surface({48, 40}, 15, 1), lights, CV_16U, 0.002,
                                             1, {}, {.strength = 0.5, .exponent = 40});
  nlohmann::json doc = {{"format", "psrig-scan/1"}, {"lights", nlohmann::json::array()}};
  for (std::size_t k = 0; k < lights.size(); ++k) {
    const std::string name = "led" + std::to_string(k) + ".png";
    ASSERT_TRUE(cv::imwrite((scan / name).string(), rendered.frames[k]));
    doc["lights"].push_back(
        {{"image", name}, {"direction", {lights[k][0], lights[k][1], lights[k][2]}}});
  }
  std::ofstream(scan / "scan.json") << doc.dump(2);
  auto run = run_program("psrig", {"process", scan.string(), "--reject", "--quiet"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(run.err.empty()) << run.err;
  std::ifstream report_file(scan / "maps" / "report.json");
  const auto report = nlohmann::json::parse(report_file);
  EXPECT_EQ(report["inputs"]["lights"], 12);
  EXPECT_EQ(report["options"]["reject_method"], "lts-reweighted");
  EXPECT_GT(report["pixels"]["highlights_rejected"].get<int>(), 0);
}

// --exr-compression and --png-level reach the maps: report.json records
// them, and ZIP makes the EXRs smaller than none does.
TEST(PsrigCli, ProcessStorageOptionsReachTheMaps) {
  TempDir temp;
  const fs::path scan = temp / "scan";
  ASSERT_EQ(
      run_program("psrig", {"synth", "--out", scan.string(), "--size", "128x96", "-q"}).exit_code,
      0);
  for (const auto& [exr, precision] : {std::pair{"none", "float"}, {"zip", "half"}}) {
    const fs::path maps = temp / exr;
    auto run =
        run_program("psrig", {"process", scan.string(), "--out", maps.string(), "--exr-compression",
                              exr, "--png-level", "9", "--map-precision", precision, "-q"});
    ASSERT_EQ(run.exit_code, 0) << run.err;
    std::ifstream report_file(maps / "report.json");
    const auto report = nlohmann::json::parse(report_file);
    EXPECT_EQ(report["options"]["exr_compression"], exr);
    EXPECT_EQ(report["options"]["png_level"], 9);
    EXPECT_EQ(report["options"]["map_precision"], precision);
  }
  EXPECT_LT(fs::file_size(temp / "zip" / "albedo.exr"),
            fs::file_size(temp / "none" / "albedo.exr"));
  EXPECT_LT(fs::file_size(temp / "zip" / "p.exr"), fs::file_size(temp / "none" / "p.exr"));
}

TEST(PsrigCli, UsageErrorsExitTwo) {
  EXPECT_EQ(run_program("psrig", {}).exit_code, 2);
  EXPECT_EQ(run_program("psrig", {"process"}).exit_code, 2);
  EXPECT_EQ(run_program("psrig", {"process", "x", "--integrate", "magic"}).exit_code, 2);
  EXPECT_EQ(run_program("psrig", {"process", "x", "--exr-compression", "dwab"}).exit_code, 2);
  EXPECT_EQ(run_program("psrig", {"process", "x", "--png-level", "10"}).exit_code, 2);
  EXPECT_EQ(run_program("psrig", {"process", "x", "--map-precision", "double"}).exit_code, 2);
  TempDir temp;
  auto bad_size = run_program("psrig", {"synth", "--out", (temp / "s").string(), "--size", "big"});
  EXPECT_EQ(bad_size.exit_code, 2);
  EXPECT_TRUE(contains(bad_size.err, "--size")) << bad_size.err;
  EXPECT_FALSE(fs::exists(temp / "s"));
  EXPECT_EQ(run_program("psrig", {"--help"}).exit_code, 0);
}

TEST(PsrigCli, ABadThreadCountSaysTheRangeInAFewWords) {
  for (const std::string command : {"process", "scan"}) {
    std::vector<std::string> args = {command, "--threads", "-1"};
    args.insert(args.begin() + 1, command == "process" ? "scan-dir" : "--config=rig.toml");
    auto run = run_program("psrig", args);
    EXPECT_EQ(run.exit_code, 2) << command;
    EXPECT_TRUE(contains(
        run.err,
        "--threads: expected a whole number of threads, 0 (one per core) or more; got '-1'"))
        << run.err;
    EXPECT_LT(run.err.size(), 200U) << run.err;  // not CLI11's largest double
  }
}

TEST(PsrigCli, ADaemonAddressThatIsNotAUrlExitsTwo) {
  for (const std::string url : {"notaurl", "127.0.0.1:8470", "http://", "http://host:port"}) {
    auto status = run_program("psrig", {"status", "--url", url});
    EXPECT_EQ(status.exit_code, 2) << url << ": " << status.err;
    EXPECT_TRUE(contains(status.err, "psrig status: error: " + url +
                                         ": --url: not a URL (expected http://HOST:PORT"))
        << status.err;
  }
  // Well-formed addresses with no daemon there: a machine error, not a bad URL.
  for (const std::string url : {"http://127.0.0.1:1", "http://[::1]", "http://[::1]:1/"}) {
    auto status = run_program("psrig", {"status", "--url", url});
    EXPECT_EQ(status.exit_code, 1) << url << ": " << status.err;
    EXPECT_FALSE(contains(status.err, "not a URL")) << status.err;
  }
  auto remote = run_program("psrig", {"scan", "--remote", "notaurl"});
  EXPECT_EQ(remote.exit_code, 2) << remote.err;
  EXPECT_TRUE(contains(remote.err, "notaurl: --remote: not a URL")) << remote.err;
}

TEST(PsrigCli, VersionPrintsTheProjectVersion) {
  auto run = run_program("psrig", {"--version"});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.out, "psrig " PSRIG_VERSION "\n");
}

// -v, -q and --version where a user types them: before the subcommand or
// after it, in all three programs.
TEST(PsrigCli, CommonFlagsGoBeforeOrAfterTheSubcommand) {
  TempDir temp;
  const auto scan = (temp / "scan").string();
  auto synth = run_program("psrig", {"synth", "--out", scan, "--size", "96x72", "-q"});
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  int n = 0;
  const auto process = [&](std::vector<std::string> args) {
    for (auto& arg : args)
      if (arg == "SCAN") arg = scan;
    args.insert(args.end(), {"--out", (temp / ("maps" + std::to_string(n++))).string()});
    return run_program("psrig", args);
  };
  for (const auto& args : {std::vector<std::string>{"-v", "process", "SCAN"},
                           std::vector<std::string>{"process", "-v", "SCAN"},
                           std::vector<std::string>{"process", "SCAN", "--verbose"}}) {
    const auto run = process(args);
    EXPECT_EQ(run.exit_code, 0) << run.err;
    EXPECT_TRUE(contains(run.err, "integration (")) << args[0] << ' ' << args[1] << ": " << run.err;
    EXPECT_FALSE(run.out.empty());
  }
  for (const auto& args : {std::vector<std::string>{"-q", "process", "SCAN"},
                           std::vector<std::string>{"process", "-q", "SCAN"},
                           std::vector<std::string>{"--quiet", "process", "SCAN"}}) {
    const auto run = process(args);
    EXPECT_EQ(run.exit_code, 0) << run.err;
    EXPECT_EQ(run.out, "") << args[0] << ' ' << args[1];
  }
  // A subcommand without a -q of its own takes the program's.
  const auto config =
      run_program("psrig", {"-q", "config", "check", PSRIG_SOURCE_DIR "/config/sim.toml"});
  EXPECT_EQ(config.exit_code, 0) << config.err;
  const auto config_after =
      run_program("psrig", {"config", "check", PSRIG_SOURCE_DIR "/config/sim.toml", "-q"});
  EXPECT_EQ(config_after.exit_code, 0) << config_after.err;
  for (const auto& args : {std::vector<std::string>{"process", "--version"},
                           std::vector<std::string>{"config", "check", "--version"}}) {
    const auto run = run_program("psrig", args);
    EXPECT_EQ(run.exit_code, 0) << run.err;
    EXPECT_EQ(run.out, "psrig " PSRIG_VERSION "\n");
  }
  const auto daemon = run_program("psrigd", {"--version"});
  EXPECT_EQ(daemon.exit_code, 0) << daemon.err;
  EXPECT_EQ(daemon.out, "psrigd " PSRIG_VERSION "\n");
  // An option nobody knows is still a usage error, wherever it is.
  const auto unknown = run_program("psrig", {"process", "--no-such-flag", scan});
  EXPECT_EQ(unknown.exit_code, 2);
}

// One way a scan can be wrong, what the message must name, and the change
// that makes it so.
struct BadScan {
  const char* name;
  const char* must_name;  // in stderr
  std::function<void(const fs::path&)> spoil;
};

void edit_json(const fs::path& scan, const std::function<void(nlohmann::json&)>& edit) {
  std::ifstream in(scan / "scan.json");
  auto doc = nlohmann::json::parse(in);
  edit(doc);
  std::ofstream(scan / "scan.json") << doc.dump(2);
}

const BadScan kBadScans[] = {
    {"zero direction", "lights[1].direction",
     [](const fs::path& s) {
       edit_json(s, [](auto& d) { d["lights"][1]["direction"] = {0, 0, 0}; });
     }},
    {"two lights", "scan.json: lights:",
     [](const fs::path& s) { edit_json(s, [](auto& d) { d["lights"].erase(2); }); }},
    {"coplanar lights", "condition number",
     [](const fs::path& s) {
       edit_json(s, [](auto& d) {
         d["lights"][0]["direction"] = {1, 0, 1};
         d["lights"][1]["direction"] = {0, 1, 1};
         d["lights"][2]["direction"] = {1, 1, 2};
       });
     }},
    {"malformed json",
     "scan.json:1:", [](const fs::path& s) { std::ofstream(s / "scan.json") << "{\"format\": }"; }},
    {"missing frame", "led2.png", [](const fs::path& s) { fs::remove(s / "led2.png"); }},
    {"corrupt frame", "led0.png",
     [](const fs::path& s) { std::ofstream(s / "led0.png") << "not an image"; }},
    {"frame of another size", "led1.png",
     [](const fs::path& s) {
       fs::copy_file(s / "small.png", s / "led1.png", fs::copy_options::overwrite_existing);
     }},
};

TEST(PsrigCli, EveryBadScanExitsTwoNamingTheProblemAndWritesNothing) {
  for (const auto& bad : kBadScans) {
    TempDir temp;
    const auto scan = temp / "scan";
    ASSERT_EQ(run_program("psrig", {"synth", "--out", scan.string(), "--size", "32x24"}).exit_code,
              0);
    ASSERT_EQ(run_program("psrig", {"synth", "--out", (temp / "small").string(), "--size", "16x16"})
                  .exit_code,
              0);
    fs::copy_file(temp / "small" / "led0.png", scan / "small.png");
    bad.spoil(scan);
    auto run = run_program("psrig", {"process", scan.string(), "--out", (temp / "maps").string()});
    EXPECT_EQ(run.exit_code, 2) << bad.name << ": " << run.err;
    EXPECT_TRUE(contains(run.err, bad.must_name)) << bad.name << ": " << run.err;
    EXPECT_EQ(list_directory(temp.path()), (std::vector<std::string>{"scan", "small"})) << bad.name;
  }
}

TEST(PsrigCli, SummaryCountsThePixelsOutsideTheMask) {
  TempDir temp;
  const auto scan = temp / "scan";
  ASSERT_EQ(run_program("psrig", {"synth", "--out", scan.string(), "--size", "32x24"}).exit_code,
            0);
  cv::Mat mask(24, 32, CV_8U, cv::Scalar(255));
  mask.colRange(0, 8).setTo(0);  // a quarter of the swatch left out
  ASSERT_TRUE(formats::write_image(scan / "mask.png", mask));
  edit_json(scan, [](auto& d) { d["mask"] = "mask.png"; });
  auto run = run_program("psrig", {"process", scan.string()});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(contains(run.out, "(outside mask 25.0 %, shadowed")) << run.out;
}

// A sphere cap of radius R (pixels) seen inside a disk, as gradient maps:
// z = sqrt(R^2 - x^2 - y^2), y up.
struct Cap {
  cv::Mat p, q, z, mask;
};
Cap sphere_cap(int w, int h, double radius, double disk) {
  Cap cap{cv::Mat(h, w, CV_32F), cv::Mat(h, w, CV_32F), cv::Mat(h, w, CV_32F),
          cv::Mat(h, w, CV_8U, cv::Scalar(0))};
  const double cx = (w - 1) / 2.0;
  const double cy = (h - 1) / 2.0;
  for (int row = 0; row < h; ++row)
    for (int col = 0; col < w; ++col) {
      const double x = col - cx;
      const double y = cy - row;
      const double z = std::sqrt(radius * radius - x * x - y * y);
      cap.z.at<float>(row, col) = static_cast<float>(z);
      cap.p.at<float>(row, col) = static_cast<float>(-x / z);
      cap.q.at<float>(row, col) = static_cast<float>(-y / z);
      if (x * x + y * y <= disk * disk) cap.mask.at<uchar>(row, col) = 255;
    }
  return cap;
}

// RMS of a - b over the mask after removing their mean difference there.
double masked_rms(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask) {
  cv::Mat d = a - b;
  const double mean = cv::mean(d, mask)[0];
  d -= mean;
  d = d.mul(d);
  return std::sqrt(cv::mean(d, mask)[0]);
}

TEST(PsrigCli, IntegrateANormalMapMadeElsewhere) {
  TempDir temp;
  const Cap cap = sphere_cap(120, 90, 80, 40);
  // A 16-bit OpenGL normal map whose background is black (no normal there).
  cv::Mat normal = formats::encode_normal16(cap.p, cap.q);
  normal.setTo(cv::Scalar(0, 0, 0), cap.mask == 0);
  ASSERT_TRUE(formats::write_image(temp / "normal.png", normal));
  const fs::path out = temp / "height.exr";
  auto run =
      run_program("psrig", {"integrate", (temp / "normal.png").string(), "--out", out.string()});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(contains(run.out, "method: masked")) << run.out;
  EXPECT_TRUE(contains(run.out, "pixels: " + std::to_string(cv::countNonZero(cap.mask))))
      << run.out;
  auto height = formats::read_image(out, "height");
  ASSERT_TRUE(height);
  ASSERT_EQ(height->type(), CV_32FC1);
  EXPECT_TRUE(std::isnan(height->at<float>(0, 0)));
  // 16-bit normals carry the slope to about 1e-4: the cap (range ~10 px)
  // comes back to a few thousandths.
  const double rms = masked_rms(*height, cap.z, cap.mask);
  EXPECT_LT(rms, 0.01) << rms;
  // Read as DirectX (green down), the same file is another surface.
  auto flipped = run_program("psrig", {"integrate", (temp / "normal.png").string(), "--out",
                                       (temp / "flipped.exr").string(), "--green-down", "-q"});
  ASSERT_EQ(flipped.exit_code, 0) << flipped.err;
  EXPECT_TRUE(flipped.out.empty()) << flipped.out;
  EXPECT_GT(masked_rms(*formats::read_image(temp / "flipped.exr", "h"), cap.z, cap.mask), 1.0);
}

TEST(PsrigCli, IntegrateGradientMapsWithAMaskAndFlatten) {
  TempDir temp;
  const Cap cap = sphere_cap(100, 80, 70, 35);
  ASSERT_TRUE(formats::write_image(temp / "p.exr", cap.p));
  ASSERT_TRUE(formats::write_image(temp / "q.exr", cap.q));
  ASSERT_TRUE(formats::write_image(temp / "mask.png", cap.mask));
  const std::string p = (temp / "p.exr").string();
  const std::string q = (temp / "q.exr").string();
  const std::string mask = (temp / "mask.png").string();
  auto run = run_program("psrig", {"integrate", p, q, "--mask", mask, "--out",
                                   (temp / "z.exr").string(), "--pixel-size", "0.1"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  // In mm, and flattened by default once a pixel size says this is a swatch:
  // the cap is a bend at this scale (a 7 mm ball under a 10 mm cut-off).
  EXPECT_TRUE(contains(run.out, "bend removed:")) << run.out;
  auto flat = formats::read_image(temp / "z.exr", "z");
  ASSERT_TRUE(flat);
  run = run_program("psrig", {"integrate", p, q, "--mask", mask, "--out", (temp / "z.exr").string(),
                              "--pixel-size", "0.1", "--flatten", "off", "--method", "masked"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_FALSE(contains(run.out, "bend removed:")) << run.out;
  auto kept = formats::read_image(temp / "z.exr", "z");
  ASSERT_TRUE(kept);
  const cv::Mat truth_mm = cap.z * 0.1;
  EXPECT_LT(masked_rms(*kept, truth_mm, cap.mask), 1e-3);
  EXPECT_GT(masked_rms(*flat, truth_mm, cap.mask), 0.05);  // the dome was taken out
  // FC on the same input, asked for by name, is far worse inside the mask.
  run = run_program("psrig", {"integrate", p, q, "--mask", mask, "--out",
                              (temp / "fc.exr").string(), "--method", "fc"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  auto fc = formats::read_image(temp / "fc.exr", "fc");
  ASSERT_TRUE(fc);
  EXPECT_TRUE(std::isnan(fc->at<float>(0, 0)));
  const double masked_px = masked_rms(*kept, truth_mm, cap.mask) / 0.1;
  EXPECT_GT(masked_rms(*fc, cap.z, cap.mask), 100 * masked_px);
}

TEST(PsrigCli, IntegrateBadInputExitsTwoNamingTheFileAndWritesNothing) {
  TempDir temp;
  const Cap cap = sphere_cap(40, 30, 50, 12);
  ASSERT_TRUE(formats::write_image(temp / "p.exr", cap.p));
  ASSERT_TRUE(formats::write_image(temp / "q.exr", cap.q));
  ASSERT_TRUE(formats::write_image(temp / "mask.png", cap.mask));
  ASSERT_TRUE(formats::write_image(temp / "small.png", cv::Mat(10, 10, CV_8U, cv::Scalar(1))));
  const std::string p = (temp / "p.exr").string();
  const std::string q = (temp / "q.exr").string();
  const std::string out = (temp / "h.exr").string();
  struct Case {
    std::vector<std::string> args;
    std::string must_name;
  };
  const std::vector<Case> cases = {
      {{"integrate", p, "--out", out}, "p.exr: NORMAL: not a normal map"},
      {{"integrate", p, (temp / "none.exr").string(), "--out", out}, "none.exr: Q: no such file"},
      {{"integrate", p, (temp / "mask.png").string(), "--out", out}, "mask.png: Q: expected"},
      {{"integrate", p, q, "--mask", (temp / "small.png").string(), "--out", out},
       "small.png: --mask: is 10x10 but the maps are 40x30"},
      {{"integrate", p, q, "--out", (temp / "h.png").string()}, "h.png: --out: the height map is"},
      {{"integrate", p, q, "--out", (temp / "no" / "h.exr").string()}, "does not exist"},
      {{"integrate", p, q, "--out", out, "--method", "magic"}, "--method"},
      {{"integrate", "--out", out}, "maps"},
  };
  for (const auto& c : cases) {
    auto run = run_program("psrig", c.args);
    EXPECT_EQ(run.exit_code, 2) << c.must_name << ": " << run.err;
    EXPECT_TRUE(contains(run.err, c.must_name)) << run.err;
  }
  EXPECT_EQ(list_directory(temp.path()),
            (std::vector<std::string>{"mask.png", "p.exr", "q.exr", "small.png"}));
}

TEST(PsrigCli, MissingScanDirectory) {
  auto run = run_program("psrig", {"process", "/nonexistent/scan"});
  EXPECT_EQ(run.exit_code, 2);
  // The input named, not the maps directory it would have held.
  EXPECT_TRUE(contains(run.err, "error: /nonexistent/scan: no such scan directory")) << run.err;
  EXPECT_FALSE(contains(run.err, "maps")) << run.err;
}

TEST(PsrigCli, ReadOnlyScanNeedsOut) {
  const auto beethoven = real_dataset("beethoven");
  if (!beethoven) GTEST_SKIP() << "shared/data/beethoven not present";
  if (::access(beethoven->c_str(), W_OK) == 0) GTEST_SKIP() << "dataset is writable here";
  auto run = run_program("psrig", {"process", beethoven->string()});
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_TRUE(contains(run.err, "cannot write")) << run.err;
  TempDir temp;
  auto with_out =
      run_program("psrig", {"process", beethoven->string(), "--out", (temp / "maps").string()});
  EXPECT_EQ(with_out.exit_code, 0) << with_out.err;
}

TEST(PsrigCli, SynthRefusesToOverwrite) {
  TempDir temp;
  const auto scan = (temp / "scan").string();
  ASSERT_EQ(run_program("psrig", {"synth", "--out", scan, "--size", "32x24"}).exit_code, 0);
  auto again = run_program("psrig", {"synth", "--out", scan, "--size", "32x24"});
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_TRUE(contains(again.err, "already exists")) << again.err;
}

TEST(PsrigCli, SynthMakesMissingParentsAndQuietPrintsNothing) {
  TempDir temp;
  const auto scan = temp / "swatches" / "2026" / "scan";
  auto run = run_program("psrig", {"synth", "--out", scan.string(), "--size", "32x24", "-q"});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(run.out.empty()) << run.out;
  EXPECT_TRUE(run.err.empty()) << run.err;
  EXPECT_TRUE(fs::exists(scan / "scan.json"));
  auto long_flag = run_program(
      "psrig", {"synth", "--out", (temp / "a" / "b").string(), "--size", "32x24", "--quiet"});
  EXPECT_EQ(long_flag.exit_code, 0) << long_flag.err;
  EXPECT_TRUE(long_flag.out.empty()) << long_flag.out;
  auto again = run_program("psrig", {"synth", "--out", scan.string(), "--size", "32x24", "-q"});
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_TRUE(contains(again.err, "already exists")) << again.err;
}

using Edits = std::vector<std::pair<std::string, std::string>>;

// config/sim.toml at a size a test affords, with scans going into `temp`
// and `edits` (text to find, what replaces it) made, written to `temp`.
fs::path sim_config(const TempDir& temp, const Edits& edits = {}) {
  std::ifstream in(fs::path(PSRIG_SOURCE_DIR) / "config/sim.toml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto replace = [&](const std::string& from, const std::string& to) {
    const auto at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
  };
  replace("width = 640", "width = 320");
  replace("height = 480", "height = 240");
  replace("root = \"../out/scans\"", "root = \"scans\"");
  for (const auto& [from, to] : edits)
    replace(from, to);
  const fs::path file = temp / "rig.toml";
  std::ofstream(file) << text;
  return file;
}

TEST(PsrigCli, ScanOnTheSimulatedRigRecoversTheSwatch) {
  TempDir temp;
  const auto config = sim_config(temp);
  const auto scan = temp / "J-0001";
  auto run = run_program("psrig", {"scan", "--config", config.string(), "--out", scan.string(),
                                   "--sample-id", "J-0001"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  std::ifstream report_file(scan / "maps/report.json");
  ASSERT_TRUE(report_file) << run.out;
  const auto report = nlohmann::json::parse(report_file);
  EXPECT_LE(report["ground_truth"]["angular_error_deg"]["mean"].get<double>(), 1.0);
  std::ifstream scan_file(scan / "scan.json");
  const auto description = nlohmann::json::parse(scan_file);
  EXPECT_EQ(description["sample"]["id"], "J-0001") << description.dump(2);
  EXPECT_TRUE(contains(description["capture"]["camera"].get<std::string>(), "simulated camera"));
}

// Near-field LEDs 250 mm away over a flat card in a 16 x 12 mm field:
// rig.toml's led_distance_mm reaches scan.json and the per-pixel solve.
TEST(PsrigCli, ScanWithNearLedsUsesTheirPositions) {
  TempDir temp;
  const auto config = sim_config(
      temp, {{"tilts_deg = [0, 120, 240]", "tilts_deg = [0, 120, 240]\nled_distance_mm = 250"},
             {"target = \"swatch\"", "target = \"flat\""},
             {"pixel_size_mm = 0.025", "pixel_size_mm = 0.05"},
             {"full_well = 10000", "full_well = 1000000"}});
  const auto scan = temp / "near";
  auto run = run_program("psrig", {"scan", "--config", config.string(), "--out", scan.string()});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  std::ifstream scan_file(scan / "scan.json");
  const auto description = nlohmann::json::parse(scan_file);
  ASSERT_TRUE(description["lights"][0].contains("position_mm")) << description.dump(2);
  EXPECT_NEAR(description["lights"][0]["position_mm"][2].get<double>(), 250 * std::sqrt(0.5), 1e-6);
  EXPECT_EQ(description["principal_point_px"], nlohmann::json::array({159.5, 119.5}));
  std::ifstream report_file(scan / "maps/report.json");
  const auto report = nlohmann::json::parse(report_file);
  EXPECT_TRUE(report["light_model"]["near_field"].get<bool>());
  EXPECT_LE(report["ground_truth"]["mean_angular_error_all_solved_deg"].get<double>(), 0.3);
}

TEST(PsrigCli, ScanWithoutAnOutGoesToTheStorageRoot) {
  TempDir temp;
  const auto config = sim_config(temp);
  auto run = run_program(
      "psrig", {"scan", "--config", config.string(), "--no-process", "--sample-id", "R 7/2"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto scans = list_directory(temp / "scans");
  ASSERT_EQ(scans.size(), 1U);
  EXPECT_TRUE(scans[0].ends_with("-R_7_2")) << scans[0];
  // scan.json, the dark frame, three LEDs and the simulator's ground truth
  EXPECT_EQ(list_directory(temp / "scans" / scans[0]).size(), 7U);
}

TEST(PsrigCli, ScanRefusesAnExistingDirectoryAndTouchesNothing) {
  TempDir temp;
  const auto config = sim_config(temp);
  fs::create_directory(temp / "taken");
  std::ofstream(temp / "taken/notes.txt") << "keep me";
  auto run = run_program("psrig",
                         {"scan", "--config", config.string(), "--out", (temp / "taken").string()});
  EXPECT_EQ(run.exit_code, 2) << run.out;
  EXPECT_TRUE(contains(run.err, "taken")) << run.err;
  EXPECT_FALSE(contains(run.err, "light 1 of 3")) << run.err;  // refused before any LED went on
  EXPECT_EQ(list_directory(temp / "taken"), std::vector<std::string>{"notes.txt"});
}

TEST(PsrigCli, ConfigErrorsNameFileLineColumnAndKey) {
  TempDir temp;
  const fs::path file = temp / "rig.toml";
  std::ofstream(file) << "[lights]\nbackend = \"gpoid\"\n";
  for (const std::string command : {"scan", "lights"}) {
    std::vector<std::string> args = {command, "--config", file.string()};
    if (command == "lights") args.push_back("--cycle");
    auto run = run_program("psrig", args);
    EXPECT_EQ(run.exit_code, 2) << command;
    EXPECT_TRUE(contains(run.err, file.string() + ":2:")) << run.err;
    EXPECT_TRUE(contains(run.err, "lights.backend")) << run.err;
    EXPECT_TRUE(contains(run.err, "gpiod")) << run.err;  // the fix
  }
  auto check = run_program("psrig", {"config", "check", file.string()});
  EXPECT_EQ(check.exit_code, 2);
  auto good = run_program(
      "psrig",
      {"config", "check", (fs::path(PSRIG_SOURCE_DIR) / "config/rig.example.toml").string()});
  EXPECT_EQ(good.exit_code, 0) << good.err;
  EXPECT_TRUE(contains(good.out, "ok")) << good.out;
}

TEST(PsrigCli, ConfigCheckWarnsOfAModbusServerOpenToAnyone) {
  TempDir temp;
  const fs::path file = temp / "rig.toml";
  std::ofstream(file) << "[daemon]\nmodbus_address = \"0.0.0.0\"\nmodbus_port = 502\n";
  auto open = run_program("psrig", {"config", "check", file.string()});
  EXPECT_EQ(open.exit_code, 0) << open.err;  // a warning, not an error
  EXPECT_TRUE(contains(open.err, "psrig config check: warning: " + file.string() + ":2:"))
      << open.err;
  EXPECT_TRUE(contains(open.err, "daemon.modbus_address")) << open.err;
  EXPECT_TRUE(contains(open.err, "daemon.modbus_allow")) << open.err;  // the fix

  std::ofstream(file) << "[daemon]\nmodbus_address = \"0.0.0.0\"\nmodbus_port = 502\n"
                         "modbus_allow = [\"192.0.2.10\"]\n";
  auto allowed = run_program("psrig", {"config", "check", file.string()});
  EXPECT_EQ(allowed.exit_code, 0) << allowed.err;
  EXPECT_FALSE(contains(allowed.err, "warning")) << allowed.err;
  EXPECT_TRUE(contains(allowed.out, "192.0.2.10")) << allowed.out;
  auto example = run_program(
      "psrig",
      {"config", "check", (fs::path(PSRIG_SOURCE_DIR) / "config/rig.example.toml").string()});
  EXPECT_EQ(example.exit_code, 0) << example.err;
  EXPECT_FALSE(contains(example.err, "warning")) << example.err;
}

TEST(PsrigCli, MissingHardwareNamesTheDeviceAndTheKey) {
  TempDir temp;
  const auto config =
      sim_config(temp, {{"backend = \"sim\"\nexposure_us",
                         "backend = \"v4l2\"\ndevice = \"/dev/video77\"\nexposure_us"}});
  auto run = run_program("psrig",
                         {"scan", "--config", config.string(), "--out", (temp / "scan").string()});
  EXPECT_NE(run.exit_code, 0);
  EXPECT_TRUE(contains(run.err, "/dev/video77")) << run.err;
  EXPECT_TRUE(contains(run.err, "camera.device")) << run.err;
  EXPECT_FALSE(fs::exists(temp / "scan"));
}

TEST(PsrigCli, AGpioChipThatIsNotThereIsBadInput) {
  TempDir temp;
  const auto config = sim_config(
      temp,
      {{"backend = \"sim\"\nchannels", "backend = \"gpiod\"\nchannels"},
       {"max_on_ms = 5000\n",
        "max_on_ms = 5000\n\n[lights.gpiod]\nchip = \"gpiochip99\"\nlines = [17, 27, 22]\n"}});
  auto run = run_program("psrig", {"lights", "--config", config.string(), "--cycle"});
  EXPECT_EQ(run.exit_code, 2) << run.err;  // the fix is the configuration
  EXPECT_TRUE(
      contains(run.err, config.string() + ": lights.gpiod.chip: GPIO chip 'gpiochip99' not found"))
      << run.err;
}

TEST(PsrigCli, LightsCycleBlinksEachLedOnce) {
  TempDir temp;
  auto run = run_program(
      "psrig", {"lights", "--config", sim_config(temp).string(), "--cycle", "--on-ms", "20"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(contains(run.out, "LED 0 on (tilt 0 deg")) << run.out;
  EXPECT_TRUE(contains(run.out, "LED 2 on (tilt 240 deg")) << run.out;
  EXPECT_TRUE(contains(run.out, "all LEDs off")) << run.out;
}

TEST(PsrigCli, DevicesListsEveryKindEvenWhenNoneIsThere) {
  auto run = run_program("psrig", {"devices"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  for (const char* section :
       {"cameras:", "GPIO chips", "USB strobe controllers 1209:5053", "serial ports"})
    EXPECT_TRUE(contains(run.out, section)) << section << "\n" << run.out;
  EXPECT_TRUE(run.err.empty()) << run.err;  // libcamera keeps quiet
}

// SIGTERM while an LED is lit, with the LEDs on a (simulated) Modbus driver
// the test holds, so it sees what the LEDs did from outside psrig.
TEST(PsrigCli, SignalMidScanTurnsEveryLedOffAndLeavesNoScan) {
  TempDir temp;
  auto driver = SimModbusDriver::start({});
  ASSERT_TRUE(driver) << driver.error().describe();
  const auto config =
      sim_config(temp, {{"backend = \"sim\"\nchannels",
                         "backend = \"modbus\"\nmodbus = { host = \"127.0.0.1\", port = " +
                             std::to_string((*driver)->port()) + " }\nchannels"},
                        {"exposure_us = 20000", "exposure_us = 200000"}});  // a slow scan

  const std::string out = (temp / "scan").string(), err = (temp / "stderr.txt").string();
  const ProgramCommand psrig("psrig", {"scan", "--config", config.string(), "--out", out});
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, psrig.file().c_str(), &actions, nullptr, psrig.argv(), environ), 0);
  posix_spawn_file_actions_destroy(&actions);

  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while ((*driver)->leds_on().empty() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_FALSE((*driver)->leds_on().empty()) << "no LED came on";
  ::kill(pid, SIGTERM);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);

  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 130);
  std::ifstream err_file(err);
  const std::string messages((std::istreambuf_iterator<char>(err_file)),
                             std::istreambuf_iterator<char>());
  EXPECT_TRUE(contains(messages, "interrupted")) << messages;
  EXPECT_TRUE((*driver)->leds_on().empty());
  EXPECT_FALSE((*driver)->log().overlap());
  EXPECT_FALSE(fs::exists(temp / "scan"));
}

}  // namespace
}  // namespace psrig::test
