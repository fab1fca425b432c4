// The preview's patch view repeats the seamless tile: the stored one when
// `psrig tile` made it, else one cut in memory; never the scan's own edges.

#include "psrig/preview/patch_tile.h"

#include <gtest/gtest.h>

#include "psrig/analysis/seamless_tile.h"
#include "psrig/formats/scan_writer.h"
#include "psrig/processing/pipeline.h"
#include "psrig/sim/synthetic_scan.h"
#include "shipped_swatch.h"
#include "test_support.h"

namespace psrig::preview {
namespace {

TEST(PatchTile, CutInMemoryThenReadFromTheTileDirectory) {
  test::TempDir temp;
  sim::SyntheticScanParams params;
  params.swatch.pattern = test::named_pattern("twill");
  params.swatch.size = {480, 360};
  params.swatch.rotation_deg = 2;
  ASSERT_TRUE(formats::write_scan(test::made(sim::make_synthetic_scan(params)), temp / "scan"));
  const auto processed = processing::process_scan(temp / "scan");
  ASSERT_TRUE(processed) << processed.error().describe();
  const auto maps = load_swatch_maps(processed->maps_directory);
  ASSERT_TRUE(maps) << maps.error().describe();

  const PatchTile cut = patch_tile(*maps);
  EXPECT_TRUE(cut.periodic) << cut.source;
  EXPECT_NE(cut.source.find("in memory"), std::string::npos) << cut.source;
  EXPECT_GE(cut.repeats_u, 2);
  EXPECT_LT(cut.maps.size().width, maps->size().width);
  EXPECT_EQ(cut.maps.normal.size(), cut.maps.albedo.size());
  EXPECT_NEAR(cut.maps.pixel_size_mm, 0.025, 0.0005);
  // Unit normals facing the camera.
  const cv::Vec3f n = cut.maps.normal.at<cv::Vec3f>(10, 10);
  EXPECT_NEAR(cv::norm(n), 1.0, 1e-4);
  EXPECT_GT(n[2], 0.5f);

  // psrig tile's directory, when there is one, is what the view repeats.
  std::vector<std::string> warnings;
  const auto read = formats::read_maps(processed->maps_directory, warnings);
  ASSERT_TRUE(read);
  const auto tile = analysis::make_seamless_tile(
      *read, analysis::find_repeat_lattice(read->height, read->albedo), {.repeats = 2});
  ASSERT_TRUE(tile);
  ASSERT_TRUE(
      analysis::write_tile(*tile, processed->maps_directory / formats::tile_files::kDirectory));
  const PatchTile stored = patch_tile(*maps);
  EXPECT_EQ(stored.source, (processed->maps_directory / formats::tile_files::kDirectory).string());
  EXPECT_EQ(stored.repeats_u, 2);
  EXPECT_EQ(stored.maps.size(), tile->maps.p.size());
  EXPECT_NEAR(stored.maps.pixel_size_mm, *tile->pixel_size_mm, 1e-12);
}

}  // namespace
}  // namespace psrig::preview
