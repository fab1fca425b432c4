// psrig export: the command line over the export library.

#include <cstdio>
#include <fstream>

#include <gtest/gtest.h>

#include "export_fixture.h"
#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;

TEST(PsrigExportCli, WritesEachFormatAndSaysItsSize) {
  TempDir dir("psrig-export-cli");
  write_known_maps(dir / "maps");
  for (const std::string format : {"glb", "gltf", "u3m", "u3ma"}) {
    const fs::path out =
        dir / (format == "glb" || format == "u3ma" ? "m." + format : "m-" + format);
    const auto run = run_program(
        "psrig", {"export", (dir / "maps").string(), "--format", format, "--out", out.string(),
                  "--whole-scan"});
    EXPECT_EQ(run.exit_code, 0) << format << ": " << run.err;
    EXPECT_TRUE(fs::exists(out)) << format;
    EXPECT_NE(run.out.find("size: 10.000 x 6.000 mm (200 x 120 px)"), std::string::npos) << run.out;
    EXPECT_TRUE(run.err.empty()) << run.err;
  }
  EXPECT_TRUE(fs::exists(dir / "m_height.png"));  // beside the .glb
}

TEST(PsrigExportCli, DirectxAddsTheFlippedNormalMap) {
  TempDir dir("psrig-export-cli");
  write_known_maps(dir / "maps");
  const auto run =
      run_program("psrig", {"export", (dir / "maps").string(), "--format", "gltf", "--out",
                            (dir / "g").string(), "--normal-convention", "directx"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(fs::exists(dir / "g" / "normal_directx.png"));
}

TEST(PsrigExportCli, WithoutPixelSizeWarnsAndExportsInPixels) {
  TempDir dir("psrig-export-cli");
  write_known_maps(dir / "maps", {.pixel_size_mm = std::nullopt});
  const auto run = run_program("psrig", {"export", (dir / "maps").string(), "--format", "glb",
                                         "--out", (dir / "a.glb").string(), "--whole-scan"});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("warning: no pixel size"), std::string::npos) << run.err;
  EXPECT_NE(run.out.find("(200 x 120 px)"), std::string::npos) << run.out;
}

// By default a maps directory is exported as its seamless tile: cut for
// the export when `psrig tile` has not stored one, the maps only read; the
// stored one when it has.
TEST(PsrigExportCli, AMapsDirectoryExportsItsSeamlessTile) {
  TempDir dir("psrig-export-cli");
  const std::string scan = (dir / "scan").string();
  ASSERT_EQ(run_program("psrig", {"synth", "--out", scan, "--size", "400x300", "-q"}).exit_code, 0);
  ASSERT_EQ(run_program("psrig", {"process", scan, "-q"}).exit_code, 0);
  const fs::path maps = dir / "scan" / "maps";
  const auto maps_before = list_directory(maps);
  fs::create_directories(dir / "cut");
  fs::create_directories(dir / "stored");
  const auto run = run_program("psrig", {"export", maps.string(), "--format", "glb", "--out",
                                         (dir / "cut" / "t.glb").string()});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(run.err.empty()) << run.err;
  EXPECT_NE(run.out.find("seamless tile"), std::string::npos) << run.out;
  EXPECT_EQ(list_directory(maps), maps_before);  // a reader never writes

  // `psrig tile` stores the same tile; the export then takes it as it is.
  ASSERT_EQ(run_program("psrig", {"tile", maps.string(), "-q"}).exit_code, 0);
  const auto tile = nlohmann::json::parse(std::ifstream(maps / "tile" / "tile.json"));
  EXPECT_TRUE(tile["periodic"].get<bool>()) << tile.dump();
  char size[96];
  std::snprintf(size, sizeof size, "size: %.3f x %.3f mm", tile["width_mm"].get<double>(),
                tile["height_mm"].get<double>());
  EXPECT_NE(run.out.find(size), std::string::npos) << run.out << " vs " << size;
  const auto stored = run_program("psrig", {"export", maps.string(), "--format", "glb", "--out",
                                            (dir / "stored" / "t.glb").string()});
  ASSERT_EQ(stored.exit_code, 0) << stored.err;
  EXPECT_TRUE(file_contents(dir / "stored" / "t.glb") == file_contents(dir / "cut" / "t.glb"));
  // The whole scan on request: 400 x 300 px.
  const auto whole = run_program("psrig", {"export", maps.string(), "--format", "glb", "--out",
                                           (dir / "w.glb").string(), "--whole-scan"});
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  EXPECT_NE(whole.out.find("(400 x 300 px)"), std::string::npos) << whole.out;
}

TEST(PsrigExportCli, BadInputExitsTwoNamingTheFile) {
  TempDir dir("psrig-export-cli");
  const auto missing = run_program("psrig", {"export", (dir / "nothing").string(), "--format",
                                             "glb", "--out", (dir / "a.glb").string()});
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find((dir / "nothing").string()), std::string::npos) << missing.err;
  write_known_maps(dir / "maps");
  fs::remove(dir / "maps" / "albedo.png");
  const auto no_albedo = run_program("psrig", {"export", (dir / "maps").string(), "--format",
                                               "u3ma", "--out", (dir / "a.u3ma").string()});
  EXPECT_EQ(no_albedo.exit_code, 2);
  EXPECT_NE(no_albedo.err.find("albedo.png"), std::string::npos) << no_albedo.err;
  const auto bad_format = run_program("psrig", {"export", (dir / "maps").string(), "--format",
                                                "fbx", "--out", (dir / "a.fbx").string()});
  EXPECT_EQ(bad_format.exit_code, 2);
  const auto no_extension = run_program("psrig", {"export", (dir / "maps").string(), "--format",
                                                  "glb", "--out", (dir / "swatch").string()});
  EXPECT_EQ(no_extension.exit_code, 2);
  EXPECT_NE(no_extension.err.find("--out: name the .glb file"), std::string::npos)
      << no_extension.err;
  const auto folder_as_file = run_program("psrig", {"export", (dir / "maps").string(), "--format",
                                                    "u3m", "--out", (dir / "s.u3m").string()});
  EXPECT_EQ(folder_as_file.exit_code, 2);
  EXPECT_NE(folder_as_file.err.find("drop the .u3m"), std::string::npos) << folder_as_file.err;
  EXPECT_EQ(list_directory(dir.path()), std::vector<std::string>{"maps"});
}

}  // namespace
}  // namespace psrig::test
