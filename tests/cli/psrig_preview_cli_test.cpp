// `psrig-preview` as a technician and a kiosk meet it: preview images of
// the right size, clear errors, a kiosk that follows new scans and keeps
// going past a broken one.

#include <chrono>
#include <fcntl.h>
#include <fstream>
#include <iterator>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;

// A real maps directory: a simulated scan of `pattern`, processed.
fs::path make_maps(const TempDir& temp, const std::string& name, const std::string& pattern) {
  const fs::path scan = temp / name;
  const auto synth = run_program(
      "psrig", {"synth", "--out", scan.string(), "--pattern", pattern, "--size", "64x48"});
  EXPECT_EQ(synth.exit_code, 0) << synth.err;
  const auto process = run_program("psrig", {"process", scan.string(), "--quiet"});
  EXPECT_EQ(process.exit_code, 0) << process.err;
  return scan / "maps";
}

TEST(PsrigPreviewCli, VersionPrintsTheProjectVersion) {
  auto run = run_program("psrig-preview", {"--version"});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.out, "psrig-preview " PSRIG_VERSION "\n");
}

TEST(PsrigPreviewCli, CommonFlagsGoAfterTheSubcommandToo) {
  for (const auto& args : {std::vector<std::string>{"render", "--version"},
                           std::vector<std::string>{"kiosk", "-v", "--version"}}) {
    const auto run = run_program("psrig-preview", args);
    EXPECT_EQ(run.exit_code, 0) << run.err;
    EXPECT_EQ(run.out, "psrig-preview " PSRIG_VERSION "\n");
  }
  const auto quiet =
      run_program("psrig-preview", {"-q", "render", "/no/such/maps", "--out", "x.png"});
  EXPECT_EQ(quiet.exit_code, 2) << quiet.err;  // -q taken; the missing maps are the error
  EXPECT_TRUE(contains(quiet.err, "/no/such/maps")) << quiet.err;
}

TEST(PsrigPreviewCli, ABadNumberSaysTheRangeInAFewWords) {
  auto fps = run_program("psrig-preview", {"kiosk", "--headless", "--fps", "0"});
  EXPECT_EQ(fps.exit_code, 2);
  EXPECT_TRUE(contains(fps.err, "--fps: expected a number above 0; got '0'")) << fps.err;
  auto distance = run_program("psrig-preview", {"knit", "x.chart", "--distance", "-5"});
  EXPECT_EQ(distance.exit_code, 2);
  EXPECT_TRUE(contains(distance.err, "--distance: expected a number, 0 or more; got '-5'"))
      << distance.err;
}

TEST(PsrigPreviewCli, RenderWritesAPreviewOfTheAskedSize) {
  TempDir temp;
  const fs::path maps = make_maps(temp, "scan", "jersey");
  const auto patch =
      run_program("psrig-preview", {"render", maps.string(), "--out", (temp / "patch.png").string(),
                                    "--size", "160x120", "--light", "point", "--yaw", "20"});
  ASSERT_EQ(patch.exit_code, 0) << patch.err;
  const cv::Mat image = cv::imread((temp / "patch.png").string());
  ASSERT_EQ(image.size(), cv::Size(160, 120));
  cv::Scalar mean, deviation;
  cv::meanStdDev(image, mean, deviation);
  EXPECT_GT(deviation[1], 10) << "a swatch, not a blank frame";

  // The flat view defaults to the maps' own size, one pixel per texel.
  const auto flat = run_program("psrig-preview", {"render", maps.string(), "--out",
                                                  (temp / "flat.png").string(), "--view", "flat"});
  ASSERT_EQ(flat.exit_code, 0) << flat.err;
  EXPECT_EQ(cv::imread((temp / "flat.png").string()).size(), cv::Size(64, 48));
}

TEST(PsrigPreviewCli, BadInputIsAClearErrorAndWritesNothing) {
  TempDir temp;
  const auto missing = run_program(
      "psrig-preview", {"render", (temp / "nowhere").string(), "--out", (temp / "p.png").string()});
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_TRUE(contains(missing.err, "nowhere")) << missing.err;
  const fs::path maps = make_maps(temp, "scan", "rib");
  const auto bad_size = run_program("psrig-preview", {"render", maps.string(), "--out",
                                                      (temp / "p.png").string(), "--size", "big"});
  EXPECT_EQ(bad_size.exit_code, 2);
  EXPECT_TRUE(contains(bad_size.err, "--size")) << bad_size.err;
  fs::remove(maps / "normal.png");
  const auto broken =
      run_program("psrig-preview", {"render", maps.string(), "--out", (temp / "p.png").string()});
  EXPECT_NE(broken.exit_code, 0);
  EXPECT_TRUE(contains(broken.err, "normal.png")) << broken.err;
  EXPECT_FALSE(fs::exists(temp / "p.png"));
}

TEST(PsrigPreviewCli, RenderOfAScanDirectorySuggestsItsMaps) {
  TempDir temp;
  const fs::path maps = make_maps(temp, "scan", "jersey");
  const fs::path scan = maps.parent_path();
  const auto run =
      run_program("psrig-preview", {"render", scan.string(), "--out", (temp / "p.png").string()});
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_TRUE(contains(run.err, "did you mean " + maps.string() + "?")) << run.err;
  EXPECT_FALSE(fs::exists(temp / "p.png"));
}

TEST(PsrigPreviewCli, HeadlessKioskOrbitsTheLight) {
  TempDir temp;
  const fs::path maps = make_maps(temp, "scan", "jersey");
  const auto kiosk = run_program(
      "psrig-preview", {"kiosk", maps.string(), "--headless", "--frames", "4", "--size", "96x72",
                        "--fps", "4", "--out-dir", (temp / "frames").string()});
  ASSERT_EQ(kiosk.exit_code, 0) << kiosk.err;
  EXPECT_TRUE(contains(kiosk.out, "showing " + maps.string())) << kiosk.out;
  ASSERT_EQ(list_directory(temp / "frames").size(), 4u);
  cv::Mat previous;
  for (int frame = 0; frame < 4; ++frame) {
    const cv::Mat image =
        cv::imread((temp / "frames" / ("frame_00000" + std::to_string(frame) + ".png")).string());
    ASSERT_EQ(image.size(), cv::Size(96, 72));
    if (!previous.empty()) {
      cv::Mat diff;
      cv::absdiff(image, previous, diff);
      EXPECT_GT(cv::mean(diff)[1], 1.0) << "frame " << frame << " moved on";
    }
    previous = image;
  }
}

bool wait_for(const fs::path& file, const std::string& text) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < deadline) {
    if (contains(file_contents(file), text)) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

TEST(PsrigPreviewCli, KioskOfAPathThatIsNotThereExitsTwoNamingIt) {
  TempDir temp;
  const fs::path frames = temp / "frames";
  for (const std::string option : {"MAPS_DIR", "--catalogue"}) {
    const std::string missing = (temp / "no-such-scans").string();
    std::vector<std::string> args = {"kiosk",  "--headless", "--frames",  "2",
                                     "--size", "32x24",      "--out-dir", frames.string()};
    if (option == "--catalogue") args.push_back("--catalogue");
    args.push_back(missing);
    const auto kiosk = run_program("psrig-preview", args);
    EXPECT_EQ(kiosk.exit_code, 2) << option << ": " << kiosk.out;
    EXPECT_TRUE(contains(kiosk.err, missing + ": " + option + ": not a directory")) << kiosk.err;
    EXPECT_FALSE(fs::exists(frames)) << option << ": no blank frames";
  }
}

// A headless kiosk running in the background, its stdout going to a file.
class BackgroundKiosk {
 public:
  BackgroundKiosk(const std::vector<std::string>& args, const fs::path& out) {
    const std::string preview = program("psrig-preview").string();
    std::vector<std::string> all = {preview, "kiosk"};
    all.insert(all.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (std::string& arg : all) argv.push_back(arg.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    spawned_ = posix_spawn(&pid_, preview.c_str(), &actions, nullptr, argv.data(), environ) == 0;
    posix_spawn_file_actions_destroy(&actions);
  }
  ~BackgroundKiosk() {
    if (spawned_ && pid_ > 0) stop();
  }
  [[nodiscard]] bool spawned() const { return spawned_; }
  // SIGTERM; the wait status.
  int stop() {
    ::kill(pid_, SIGTERM);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = 0;
    return status;
  }

 private:
  pid_t pid_ = 0;
  bool spawned_ = false;
};

TEST(PsrigPreviewCli, KioskFollowsNewScansAndSkipsABrokenOne) {
  TempDir temp;
  const fs::path catalogue = temp / "catalogue";
  fs::create_directories(catalogue);
  // Scans are made beside the catalogue and moved in whole, as the rig does.
  make_maps(temp, "first", "jersey");
  fs::rename(temp / "first", catalogue / "first");

  const fs::path out = temp / "stdout.txt";
  BackgroundKiosk kiosk({"--catalogue", catalogue.string(), "--headless", "--frames", "20000",
                         "--size", "48x36", "--samples", "0", "--out-dir",
                         (temp / "frames").string()},
                        out);
  ASSERT_TRUE(kiosk.spawned());

  EXPECT_TRUE(wait_for(out, "showing " + (catalogue / "first" / "maps").string()))
      << file_contents(out);
  // A scan whose maps are broken: reported, and the first one stays up.
  make_maps(temp, "broken", "rib");
  fs::resize_file(temp / "broken" / "maps" / "normal.png", 100);
  fs::rename(temp / "broken", catalogue / "broken");
  EXPECT_TRUE(wait_for(out, "cannot show " + (catalogue / "broken" / "maps").string()))
      << file_contents(out);
  // The next good scan is shown.
  make_maps(temp, "third", "garter");
  fs::rename(temp / "third", catalogue / "third");
  EXPECT_TRUE(wait_for(out, "showing " + (catalogue / "third" / "maps").string()))
      << file_contents(out);

  const int status = kiosk.stop();
  ASSERT_TRUE(WIFEXITED(status)) << "the kiosk ends cleanly on SIGTERM";
  EXPECT_EQ(WEXITSTATUS(status), 0);
  EXPECT_TRUE(contains(file_contents(out), "kiosk: stopped"));
}

// With --drape, as on the display: each new scan's chart is read and
// knitted in the background while its swatch shows; a woven scan keeps
// the swatch and says why; the kiosk still ends cleanly on SIGTERM with a
// knit in hand.
TEST(PsrigPreviewCli, KioskDrapesEachNewKnitInTheBackground) {
  TempDir temp;
  const fs::path catalogue = temp / "catalogue";
  fs::create_directories(catalogue);
  const auto scan = [&](const std::string& name, const std::string& pattern) {
    const auto maps = synth_and_process(temp / name, pattern);
    ASSERT_TRUE(maps) << maps.error();
    fs::rename(temp / name, catalogue / name);
  };
  scan("first", "stripes");

  const fs::path out = temp / "stdout.txt";
  BackgroundKiosk kiosk({"--catalogue", catalogue.string(), "--headless", "--frames", "20000",
                         "--size", "64x48", "--samples", "0", "--drape", "sphere",
                         "--drape-in-background", "--swatch-seconds", "0.1", "--drape-seconds",
                         "0.1", "--drape-stitches", "12", "--drape-rows", "12", "--out-dir",
                         (temp / "frames").string()},
                        out);
  ASSERT_TRUE(kiosk.spawned());
  EXPECT_TRUE(wait_for(out, "draping " + (catalogue / "first" / "maps").string()))
      << file_contents(out);
  scan("second", "plain");
  EXPECT_TRUE(wait_for(out, "no drape for " + (catalogue / "second" / "maps").string()))
      << file_contents(out);
  scan("third", "seed");
  EXPECT_TRUE(wait_for(out, "draping " + (catalogue / "third" / "maps").string()))
      << file_contents(out);
  scan("fourth", "rib-1x1");  // stopped while it may still be knitting
  EXPECT_TRUE(wait_for(out, "showing " + (catalogue / "fourth" / "maps").string()))
      << file_contents(out);

  const int status = kiosk.stop();
  ASSERT_TRUE(WIFEXITED(status)) << "the kiosk ends cleanly on SIGTERM";
  EXPECT_EQ(WEXITSTATUS(status), 0);
  EXPECT_TRUE(contains(file_contents(out), "kiosk: stopped"));
}

TEST(PsrigPreviewCli, BenchPrintsFramesPerSecond) {
  TempDir temp;
  const fs::path maps = make_maps(temp, "scan", "jersey");
  const auto bench = run_program("psrig-preview", {"bench", maps.string(), "--size", "64x48",
                                                   "--frames", "5", "--warmup", "1"});
  ASSERT_EQ(bench.exit_code, 0) << bench.err;
  const auto report = nlohmann::json::parse(bench.out);
  EXPECT_GT(report["fps"].get<double>(), 0);
  EXPECT_LE(report["frame_ms"]["p50"].get<double>(), report["frame_ms"]["max"].get<double>());
  EXPECT_EQ(report["size"], nlohmann::json::array({64, 48}));
}

// Of the pixels inside the cloth's bounding box, the share that is yarn.
double yarn_share(const cv::Mat& image) {
  cv::Mat grey, yarn;
  cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  cv::threshold(grey, yarn, 40, 255, cv::THRESH_BINARY);
  const cv::Rect box = cv::boundingRect(yarn);
  return box.area() == 0 ? 0.0 : cv::countNonZero(yarn(box)) / static_cast<double>(box.area());
}

TEST(PsrigPreviewCli, KnitLodForcesALevel) {
  // Far enough that auto draws the far level (yarns about 1.5 px): --lod
  // far draws the same frame, --lod near another; a level not offered is
  // bad input.
  TempDir temp;
  const auto knit = [&](const std::string& lod) {
    const fs::path out = temp / (lod + ".png");
    const auto run =
        run_program("psrig-preview",
                    {"knit", shipped_pattern("stockinette.chart").string(), "--out", out.string(),
                     "--size", "240x180", "--stitches", "30", "--rows", "30", "--lod", lod});
    EXPECT_EQ(run.exit_code, 0) << run.err;
    return cv::imread(out.string());
  };
  const cv::Mat automatic = knit("auto"), far = knit("far"), near = knit("near");
  ASSERT_FALSE(automatic.empty() || far.empty() || near.empty());
  EXPECT_EQ(cv::norm(automatic, far, cv::NORM_L1), 0.0) << "auto draws the far level here";
  EXPECT_GT(cv::norm(automatic, near, cv::NORM_L1), 0.0) << "near is another level";
  const auto bad =
      run_program("psrig-preview", {"knit", "x.chart", "--out", "x.png", "--lod", "medium"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--lod"), std::string::npos) << bad.err;
}

TEST(PsrigPreviewCli, KnitWeaveFarLevelIsNeuralOrBaked) {
  // A weave's far level is the repeat baked at the near level unless
  // --woven-far neural asks for the neural woven BSDF's: two different
  // pictures of the same cloth; --bench says which it drew.
  TempDir temp;
  const auto knit = [&](const std::string& far) {
    const fs::path out = temp / (far + ".png");
    const auto run =
        run_program("psrig-preview", {"knit", shipped_pattern("twill-2x2.weave").string(), "--out",
                                      out.string(), "--size", "240x180", "--stitches", "40",
                                      "--rows", "40", "--lod", "far", "--woven-far", far});
    EXPECT_EQ(run.exit_code, 0) << run.err;
    return cv::imread(out.string());
  };
  const cv::Mat neural = knit("neural"), baked = knit("baked");
  ASSERT_FALSE(neural.empty() || baked.empty());
  EXPECT_GT(cv::norm(neural, baked, cv::NORM_L1), 0.0) << "two levels, two pictures";
  const auto bench = run_program(
      "psrig-preview", {"knit", shipped_pattern("twill-2x2.weave").string(), "--bench", "--size",
                        "160x120", "--bench-stitches", "100", "--frames", "1", "--lod", "far"});
  EXPECT_EQ(bench.exit_code, 0) << bench.err;
  EXPECT_NE(bench.out.find("\"far_cloth\": \"baked\""), std::string::npos) << bench.out;
  const auto bad =
      run_program("psrig-preview", {"knit", "x.weave", "--out", "x.png", "--woven-far", "painted"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--woven-far"), std::string::npos) << bad.err;
}

TEST(PsrigPreviewCli, KnitDrawsYarnsAndStretchOpensGaps) {
  TempDir temp;
  const auto knit = [&](const std::string& name, std::vector<std::string> extra,
                        const std::string& light_slant = "0") {
    std::vector<std::string> args = {"knit",          shipped_pattern("stockinette.chart").string(),
                                     "--out",         (temp / name).string(),
                                     "--size",        "320x240",
                                     "--stitches",    "8",
                                     "--rows",        "6",
                                     "--distance",    "22",
                                     "--light-slant", light_slant};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto run = run_program("psrig-preview", args);
    EXPECT_EQ(run.exit_code, 0) << run.err;
    return cv::imread((temp / name).string());
  };
  const cv::Mat rest = knit("rest.png", {});
  const cv::Mat stretched = knit("stretched.png", {"--stretch", "1.5"});
  ASSERT_EQ(rest.size(), cv::Size(320, 240));
  EXPECT_GT(yarn_share(rest), 0.4) << "a knitted cloth, not a blank frame";
  EXPECT_LT(yarn_share(stretched), yarn_share(rest) - 0.05) << "stretched loops open gaps";
  const cv::Mat draped = knit("draped.png", {"--draped", "--pitch", "30"});
  EXPECT_GT(cv::norm(draped, rest, cv::NORM_L1), 0.0) << "the cloth laid over the patch";
  EXPECT_GT(yarn_share(draped), 0.2);
  const cv::Mat coloured = knit("green.png", {"--yarn-color", "#20C040"});
  const cv::Scalar mean = cv::mean(coloured);
  EXPECT_GT(mean[1], mean[2] + 5) << "green yarn";  // BGR
  // Under a grazing light, yarns shadow the yarns beside them: without the
  // shadow map the same cloth is brighter.
  const cv::Mat grazing = knit("grazing.png", {}, "70");
  const cv::Mat unshadowed = knit("unshadowed.png", {"--no-shadows"}, "70");
  EXPECT_GT(cv::mean(unshadowed)[2], cv::mean(grazing)[2] + 1) << "--no-shadows drops the shadows";
  const cv::Mat plain = knit("plain.png", {"--plain-fibres"});
  EXPECT_GT(cv::norm(plain, rest, cv::NORM_L1) / static_cast<double>(rest.total()), 0.5)
      << "--plain-fibres drops the ply grooves";

  const auto woven =
      run_program("psrig-preview", {"knit", shipped_pattern("satin-5.weave").string(), "--out",
                                    (temp / "satin.png").string(), "--size", "160x120",
                                    "--stitches", "20", "--rows", "20"});
  ASSERT_EQ(woven.exit_code, 0) << woven.err;
  EXPECT_GT(yarn_share(cv::imread((temp / "satin.png").string())), 0.5);
}

// --from-scan without a chart: the chart read off a scan of two-course
// stripes, drawn in both its colours; with a chart, that chart in the
// scan's colours; a scan with no chart to read is a clear error.
TEST(PsrigPreviewCli, KnitFromScanDrawsTheChartReadOffIt) {
  TempDir temp;
  const fs::path scan = temp / "stripes";
  const auto synth = run_program("psrig", {"synth", "--out", scan.string(), "--pattern", "stripes",
                                           "--size", "400x400", "--pixel-size", "0.03", "-q"});
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  const auto process = run_program("psrig", {"process", scan.string(), "-q"});
  ASSERT_EQ(process.exit_code, 0) << process.err;
  const auto draw = [&](const std::string& name, std::vector<std::string> pattern) {
    std::vector<std::string> args = {"knit"};
    args.insert(args.end(), pattern.begin(), pattern.end());
    for (const std::string& arg : {std::string("--from-scan"), (scan / "maps").string(),
                                   std::string("--out"), (temp / name).string(),
                                   std::string("--size"), std::string("320x240"),
                                   std::string("--stitches"), std::string("8"),
                                   std::string("--rows"), std::string("8"),
                                   std::string("--distance"), std::string("14")})
      args.push_back(arg);
    return run_program("psrig-preview", args);
  };
  // Dark navy and light cream yarn: grey levels far apart in one frame.
  const auto both_colours = [](const cv::Mat& image) {
    cv::Mat grey;
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
    return cv::countNonZero(grey > 150) > 500 && cv::countNonZero((grey < 70) & (grey > 5)) > 500;
  };
  const auto read_off = draw("read.png", {});
  ASSERT_EQ(read_off.exit_code, 0) << read_off.err;
  EXPECT_TRUE(contains(read_off.out, "chart 1 x 4 read off")) << read_off.out;
  EXPECT_TRUE(contains(read_off.out, "2 colours")) << read_off.out;
  EXPECT_TRUE(both_colours(cv::imread((temp / "read.png").string()))) << "stripes, not one colour";
  const auto given = draw("given.png", {shipped_pattern("seed.chart").string()});
  ASSERT_EQ(given.exit_code, 0) << given.err;
  EXPECT_TRUE(both_colours(cv::imread((temp / "given.png").string())));

  const fs::path woven = make_maps(temp, "plain", "plain");
  const auto refused = run_program("psrig-preview", {"knit", "--from-scan", woven.string(),
                                                     "--out", (temp / "woven.png").string()});
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_TRUE(contains(refused.err, "no stitch chart could be read off")) << refused.err;
  EXPECT_FALSE(fs::exists(temp / "woven.png"));
  const auto nothing = run_program("psrig-preview", {"knit", "--out", (temp / "n.png").string()});
  EXPECT_EQ(nothing.exit_code, 2);
  EXPECT_TRUE(contains(nothing.err, "give a stitch chart")) << nothing.err;
}

TEST(PsrigPreviewCli, KnitBadInputNamesTheFileAndLine) {
  TempDir temp;
  const fs::path ragged = temp / "ragged.chart";
  std::ofstream(ragged) << "KKPP\nKKP\n";
  const auto bad =
      run_program("psrig-preview", {"knit", ragged.string(), "--out", (temp / "k.png").string()});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_TRUE(contains(bad.err, "ragged.chart:2")) << bad.err;
  const auto colour =
      run_program("psrig-preview", {"knit", shipped_pattern("seed.chart").string(), "--out",
                                    (temp / "k.png").string(), "--yarn-color", "red"});
  EXPECT_EQ(colour.exit_code, 2);
  EXPECT_TRUE(contains(colour.err, "--yarn-color")) << colour.err;
  const auto missing = run_program("psrig-preview", {"knit", (temp / "none.chart").string(),
                                                     "--out", (temp / "k.png").string()});
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_TRUE(contains(missing.err, "none.chart")) << missing.err;
  EXPECT_FALSE(fs::exists(temp / "k.png"));
}

TEST(PsrigPreviewCli, KnitOfAMissingPatternExitsTwo) {
  TempDir temp;
  for (const char* name : {"absent.chart", "absent.weave"}) {
    const auto run = run_program(
        "psrig-preview", {"knit", (temp / name).string(), "--out", (temp / "knit.png").string()});
    EXPECT_EQ(run.exit_code, 2) << run.err;
    EXPECT_TRUE(contains(run.err, (temp / name).string() + ": no such pattern file")) << run.err;
  }
  EXPECT_FALSE(fs::exists(temp / "knit.png"));
}

TEST(PsrigPreviewCli, KnitBenchTimesThreeSizes) {
  const auto bench =
      run_program("psrig-preview", {"knit", shipped_pattern("stockinette.chart").string(),
                                    "--bench", "--size", "160x120", "--frames", "1"});
  ASSERT_EQ(bench.exit_code, 0) << bench.err;
  const auto report = nlohmann::json::parse(bench.out);
  ASSERT_EQ(report["runs"].size(), 3U);
  EXPECT_EQ(report["runs"][1]["stitches"], 10000);
  for (const auto& run : report["runs"]) {
    EXPECT_GT(run["yarn_update_ms"].get<double>(), 0);
    EXPECT_GT(run["fps"].get<double>(), 0);
  }
}

}  // namespace
}  // namespace psrig::test
