// glTF export: every export passes the Khronos glTF-Validator with no errors
// and no warnings; read back with tinygltf it gives the same textures and a
// quad of the material's physical size.

#include "psrig/export/gltf_export.h"

#include <cmath>
#include <fstream>
#include <tiny_gltf.h>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "export_fixture.h"
#include "psrig/export/export_format.h"
#include "psrig/export/material_source.h"
#include "psrig/export/occlusion.h"
#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;
using export_::ExportFormat;

// tinygltf without stb: images decoded by OpenCV, as psrig wrote them.
bool decode_with_opencv(tinygltf::Image* image, const int, std::string* err, std::string*, int, int,
                        const unsigned char* bytes, int size, void*) {
  const cv::Mat decoded = cv::imdecode(cv::Mat(1, size, CV_8U, const_cast<unsigned char*>(bytes)),
                                       cv::IMREAD_UNCHANGED);
  if (decoded.empty()) {
    if (err) *err = "cannot decode image";
    return false;
  }
  image->width = decoded.cols;
  image->height = decoded.rows;
  image->component = decoded.channels();
  image->bits = decoded.depth() == CV_16U ? 16 : 8;
  image->image.assign(decoded.datastart, decoded.dataend);  // BGR, as OpenCV keeps it
  return true;
}

cv::Mat as_mat(const tinygltf::Image& image) {
  return cv::Mat(image.height, image.width, CV_8UC(image.component),
                 const_cast<unsigned char*>(image.image.data()))
      .clone();
}

tinygltf::Model load(const fs::path& file) {
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(decode_with_opencv, nullptr);
  tinygltf::Model model;
  std::string err, warn;
  const bool ok = file.extension() == ".glb"
                      ? loader.LoadBinaryFromFile(&model, &err, &warn, file.string())
                      : loader.LoadASCIIFromFile(&model, &err, &warn, file.string());
  EXPECT_TRUE(ok) << err;
  return model;
}

// The validator's verdict: 0 errors, 0 warnings (infos are listed).
void expect_valid(const fs::path& file) {
  std::string why;
  const auto validator = find_validator("validate-gltf.mjs", why);
  if (!validator) GTEST_SKIP() << "glTF-Validator not run: " << why;
  const auto report = run_json(validator->command + " '" + file.string() + "'");
  ASSERT_TRUE(report.contains("issues")) << report.dump(2);
  EXPECT_EQ(report["issues"]["numErrors"], 0) << report["issues"].dump(2);
  EXPECT_EQ(report["issues"]["numWarnings"], 0) << report["issues"].dump(2);
  for (const auto& message : report["issues"]["messages"])
    std::printf("glTF-Validator %s: %s %s\n", file.filename().c_str(),
                message["code"].get<std::string>().c_str(),
                message["message"].get<std::string>().c_str());
}

struct QuadSize {
  double width_m = 0;
  double height_m = 0;
};
QuadSize quad_size(const tinygltf::Model& model) {
  const auto& accessor = model.accessors[model.meshes[0].primitives[0].attributes.at("POSITION")];
  return {accessor.maxValues[0] - accessor.minValues[0],
          accessor.maxValues[1] - accessor.minValues[1]};
}

class GltfExport : public ::testing::TestWithParam<ExportFormat> {};

TEST_P(GltfExport, ValidatesAndReadsBackAtPhysicalSize) {
  TempDir dir("psrig-gltf");
  const KnownMaps maps = write_known_maps(dir / "maps");
  auto source = export_::material_source_from(maps.directory);
  ASSERT_TRUE(source) << source.error().describe();
  EXPECT_TRUE(source->warnings.empty());
  const bool binary = GetParam() == ExportFormat::glb;
  const fs::path out = dir / (binary ? "swatch.glb" : "swatch");
  auto result = export_::export_material(*source, GetParam(), out);
  ASSERT_TRUE(result) << result.error().describe();
  const fs::path file = binary ? out : out / "swatch.gltf";
  ASSERT_TRUE(fs::exists(file));

  const tinygltf::Model model = load(file);
  ASSERT_EQ(model.meshes.size(), 1u);
  const QuadSize size = quad_size(model);
  // 200 x 120 px at 0.05 mm: 10 x 6 mm.
  EXPECT_NEAR(size.width_m, 0.010, 0.010 * 0.001);
  EXPECT_NEAR(size.height_m, 0.006, 0.006 * 0.001);

  const auto& material = model.materials.at(0);
  const auto& albedo = model.images.at(
      model.textures.at(material.pbrMetallicRoughness.baseColorTexture.index).source);
  const auto& normal = model.images.at(model.textures.at(material.normalTexture.index).source);
  EXPECT_EQ(cv::norm(as_mat(albedo), maps.albedo, cv::NORM_INF), 0.0);
  cv::Mat normal8;
  maps.normal.convertTo(normal8, CV_8U, 1.0 / 257.0);
  EXPECT_EQ(cv::norm(as_mat(normal), normal8, cv::NORM_INF), 0.0);
  ASSERT_GE(material.occlusionTexture.index, 0);  // derived from the height map
  const cv::Mat occlusion =
      as_mat(model.images.at(model.textures.at(material.occlusionTexture.index).source));
  EXPECT_EQ(occlusion.size(), maps.albedo.size());
  EXPECT_GT(cv::mean(occlusion)[0], 128);  // ribs this shallow hide little of the sky
  EXPECT_TRUE(material.extensions.contains("KHR_materials_sheen"));
  EXPECT_TRUE(
      material.pbrMetallicRoughness.baseColorTexture.extensions.contains("KHR_texture_transform"));
  EXPECT_EQ(model.samplers.at(0).wrapS, TINYGLTF_TEXTURE_WRAP_REPEAT);

  // The height map beside, and what its grey levels mean.
  const auto& height = material.extras.Get("psrig").Get("height");
  ASSERT_TRUE(height.IsObject());
  const fs::path height_file = file.parent_path() / height.Get("uri").Get<std::string>();
  const cv::Mat grey = cv::imread(height_file.string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(grey.type(), CV_16UC1);
  const double low = height.Get("low").GetNumberAsDouble();
  const double high = height.Get("high").GetNumberAsDouble();
  cv::Mat mm;
  grey.convertTo(mm, CV_32F, (high - low) / 65535.0, low);
  EXPECT_LT(cv::norm(mm, maps.height, cv::NORM_INF), (maps.high - maps.low) / 65535.0);

  expect_valid(file);
}

INSTANTIATE_TEST_SUITE_P(BinaryAndFolder, GltfExport,
                         ::testing::Values(ExportFormat::glb, ExportFormat::gltf),
                         [](const auto& param_info) {
                           return std::string(export_::to_string(param_info.param));
                         });

TEST(GltfExport, RepeatsScaleTheQuadAndTheTextureTransform) {
  TempDir dir("psrig-gltf");
  write_known_maps(dir / "maps");
  auto source = export_::material_source_from(dir / "maps");
  ASSERT_TRUE(source);
  auto result = export_::export_material(*source, ExportFormat::glb, dir / "r.glb", {false, 3});
  ASSERT_TRUE(result) << result.error().describe();
  const auto model = load(dir / "r.glb");
  EXPECT_NEAR(quad_size(model).width_m, 0.030, 0.030 * 0.001);
  const auto& transform =
      model.materials[0]
          .pbrMetallicRoughness.baseColorTexture.extensions.at("KHR_texture_transform")
          .Get("scale");
  EXPECT_EQ(transform.Get(0).GetNumberAsDouble(), 3.0);
  expect_valid(dir / "r.glb");
}

TEST(GltfExport, WithoutPixelSizeExportsInPixelsAndWarns) {
  TempDir dir("psrig-gltf");
  write_known_maps(dir / "maps", {.pixel_size_mm = std::nullopt});
  auto source = export_::material_source_from(dir / "maps");
  ASSERT_TRUE(source);
  ASSERT_EQ(source->warnings.size(), 1u);
  EXPECT_NE(source->warnings[0].find("pixel_size_mm"), std::string::npos) << source->warnings[0];
  auto result = export_::export_material(*source, ExportFormat::glb, dir / "px.glb");
  ASSERT_TRUE(result);
  EXPECT_NEAR(quad_size(load(dir / "px.glb")).width_m, 0.200, 1e-6);  // 200 px as 200 mm
  expect_valid(dir / "px.glb");
}

TEST(GltfExport, WithoutReportExportsAndWarns) {
  TempDir dir("psrig-gltf");
  write_known_maps(dir / "maps", {.report = false});
  auto source = export_::material_source_from(dir / "maps");
  ASSERT_TRUE(source);
  ASSERT_GE(source->warnings.size(), 1u);
  EXPECT_NE(source->warnings[0].find("report.json"), std::string::npos) << source->warnings[0];
  auto result = export_::export_material(*source, ExportFormat::glb, dir / "nr.glb");
  ASSERT_TRUE(result) << result.error().describe();
  expect_valid(dir / "nr.glb");
}

TEST(GltfExport, WithoutHeightStillValid) {
  TempDir dir("psrig-gltf");
  write_known_maps(dir / "maps", {.height_map = false});
  auto source = export_::material_source_from(dir / "maps");
  ASSERT_TRUE(source);
  auto result = export_::export_material(*source, ExportFormat::gltf, dir / "nh");
  ASSERT_TRUE(result) << result.error().describe();
  EXPECT_FALSE(fs::exists(dir / "nh" / "height.png"));
  expect_valid(dir / "nh" / "nh.gltf");
}

TEST(GltfExport, TileDirectoryGivesItsSizeAndSaysSeamless) {
  TempDir dir("psrig-gltf");
  write_known_maps(dir / "tile", {.report = false});
  std::ofstream(dir / "tile" / "tile.json")
      << R"({"format": "psrig-tile/1", "width_px": 200, "height_px": 120, "pixel_size_mm": 0.04,
            "width_mm": 8.0, "height_mm": 4.8, "repeats": [5, 3], "periodic": true})";
  auto source = export_::material_source_from(dir / "tile");
  ASSERT_TRUE(source) << source.error().describe();
  EXPECT_TRUE(source->tile);
  EXPECT_TRUE(source->warnings.empty());
  auto result = export_::export_material(*source, ExportFormat::glb, dir / "t.glb");
  ASSERT_TRUE(result) << result.error().describe();
  const auto model = load(dir / "t.glb");
  EXPECT_NEAR(quad_size(model).width_m, 0.008, 0.008 * 0.001);
  EXPECT_NEAR(quad_size(model).height_m, 0.0048, 0.0048 * 0.001);
  EXPECT_TRUE(model.materials[0].extras.Get("psrig").Get("seamless_tile").Get<bool>());
  expect_valid(dir / "t.glb");

  std::ofstream(dir / "tile" / "tile.json") << R"({"format": "psrig-tile/9"})";
  auto wrong = export_::material_source_from(dir / "tile");
  ASSERT_FALSE(wrong);
  EXPECT_EQ(wrong.error().kind, ErrorKind::bad_input);
  EXPECT_NE(wrong.error().describe().find("tile.json"), std::string::npos);
}

TEST(AmbientOcclusion, PlanesAreOpenAndAGrooveBottomKeepsWhatGeometrySays) {
  const double s = 0.02;
  cv::Mat plane(40, 60, CV_32F), groove(40, 60, CV_32F);
  for (int r = 0; r < 40; ++r)
    for (int c = 0; c < 60; ++c) {
      plane.at<float>(r, c) = static_cast<float>(0.3 * c * s - 0.2 * r * s);
      groove.at<float>(r, c) = static_cast<float>(std::abs(c - 30) * s);  // 45 degree walls
    }
  double low = 0, high = 0;
  cv::minMaxLoc(export_::ambient_occlusion(plane, s, 8), &low, &high);
  EXPECT_NEAR(low, 1.0, 1e-5);
  EXPECT_NEAR(high, 1.0, 1e-5);
  // At the bottom: the walls rise at 45 degrees across the groove (sin 0.707)
  // and at atan(cos 45) on the diagonals (sin 0.577), not along it:
  // 1 - (2 x 0.7071 + 4 x 0.5774) / 8 = 0.5345.
  const cv::Mat ao = export_::ambient_occlusion(groove, s, 8);
  EXPECT_NEAR(ao.at<float>(20, 30), 0.5345, 0.005);
  // NaN heights count as the lowest: no NaN comes out.
  groove.at<float>(5, 5) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_TRUE(cv::checkRange(export_::ambient_occlusion(groove, s, 8)));
}

TEST(GltfExport, MissingNormalMapIsBadInputNamingTheFile) {
  TempDir dir("psrig-gltf");
  write_known_maps(dir / "maps");
  fs::remove(dir / "maps" / "normal.png");
  auto source = export_::material_source_from(dir / "maps");
  ASSERT_FALSE(source);
  EXPECT_EQ(source.error().kind, ErrorKind::bad_input);
  EXPECT_NE(source.error().describe().find("normal.png"), std::string::npos);
}

TEST(GltfExport, UnwritableOutputFailsAndLeavesNothing) {
  // /proc takes no new files, not even from root (tests may run as root).
  TempDir dir("psrig-gltf");
  write_known_maps(dir / "maps");
  auto source = export_::material_source_from(dir / "maps");
  ASSERT_TRUE(source);
  for (const auto format : {ExportFormat::glb, ExportFormat::gltf}) {
    const fs::path out =
        format == ExportFormat::glb ? "/proc/psrig-export-test.glb" : "/proc/psrig-export-test";
    auto result = export_::export_material(*source, format, out);
    ASSERT_FALSE(result);
    EXPECT_NE(result.error().describe().find("/proc/psrig-export-test"), std::string::npos)
        << result.error().describe();
    EXPECT_FALSE(fs::exists(out));
  }
  for (const auto& entry : fs::directory_iterator("/proc"))
    EXPECT_EQ(entry.path().filename().string().find("psrig-export-test"), std::string::npos);
}

TEST(GltfExport, OutputInAMissingFolderIsBadInputAndLeavesNothing) {
  TempDir dir("psrig-gltf");
  write_known_maps(dir / "maps");
  auto source = export_::material_source_from(dir / "maps");
  ASSERT_TRUE(source);
  auto result = export_::export_material(*source, ExportFormat::glb, dir / "nowhere" / "a.glb");
  ASSERT_FALSE(result);
  EXPECT_EQ(result.error().kind, ErrorKind::bad_input);
  EXPECT_EQ(list_directory(dir.path()), std::vector<std::string>{"maps"});
}

TEST(GltfExport, RefusesToReplaceAFolderThatIsNotAnExport) {
  TempDir dir("psrig-gltf");
  write_known_maps(dir / "maps");
  auto source = export_::material_source_from(dir / "maps");
  ASSERT_TRUE(source);
  fs::create_directories(dir / "precious");
  std::ofstream(dir / "precious" / "thesis.txt") << "keep me";
  auto result = export_::export_material(*source, ExportFormat::gltf, dir / "precious");
  ASSERT_FALSE(result);
  EXPECT_EQ(result.error().kind, ErrorKind::bad_input);
  EXPECT_TRUE(fs::exists(dir / "precious" / "thesis.txt"));
  // An earlier export is replaced.
  ASSERT_TRUE(export_::export_material(*source, ExportFormat::gltf, dir / "again"));
  ASSERT_TRUE(export_::export_material(*source, ExportFormat::gltf, dir / "again"));
  EXPECT_TRUE(fs::exists(dir / "again" / "again.gltf"));
}

}  // namespace
}  // namespace psrig::test
