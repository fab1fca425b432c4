// U3M export: the .u3m validates against the U3M 1.1 schema (when
// ../shared/standards is there), and keeps the rules the schema cannot
// express (u3m_additional_spec*.txt): sizes in mm that agree with the
// pixels and DPI, OpenGL normals, a displacement whose factor and offset give
// the heights back in mm, and a .u3ma zip within the container's
// restrictions, checked byte by byte.

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <zlib.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "export_fixture.h"
#include "psrig/export/export_format.h"
#include "psrig/export/material_source.h"
#include "psrig/formats/map_encoding.h"
#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;
using export_::ExportFormat;
using nlohmann::json;

std::vector<unsigned char> read_bytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

cv::Mat decode(const std::vector<unsigned char>& bytes) {
  return cv::imdecode(
      cv::Mat(1, static_cast<int>(bytes.size()), CV_8U, const_cast<unsigned char*>(bytes.data())),
      cv::IMREAD_UNCHANGED);
}

void expect_schema_valid(const fs::path& document) {
  const auto standard = u3m_standard();
  if (!standard) GTEST_SKIP() << "../shared/standards/u3m-1.1 is absent: schema not checked";
  std::string why;
  const auto validator = find_validator("validate-json-schema.mjs", why);
  if (!validator) GTEST_SKIP() << "JSON schema validator not run: " << why;
  const json verdict =
      run_json(validator->command + " '" + (*standard / "u3m_schema.json").string() + "' '" +
               document.string() + "'");
  EXPECT_EQ(verdict.value("valid", false), true) << verdict.dump(2);
}

// The additional rules on one image object (u3m_additional_spec_u3m.txt:
// "Dpi in material and images should match. Same goes for the dpi that can
// be calculated from width & height and the image size").
void expect_image_consistent(const json& image, const cv::Mat& pixels, double width_mm,
                             double height_mm) {
  EXPECT_NEAR(image["width"].get<double>(), width_mm, 1e-9);
  EXPECT_NEAR(image["height"].get<double>(), height_mm, 1e-9);
  EXPECT_NEAR(image["dpi"]["x"].get<double>() * image["width"].get<double>() / 25.4, pixels.cols,
              1e-6);
  EXPECT_NEAR(image["dpi"]["y"].get<double>() * image["height"].get<double>() / 25.4, pixels.rows,
              1e-6);
}

// The files of a U3M: from its folder, or from its archive.
using Files = std::map<std::string, std::vector<unsigned char>>;

void check_document(const json& doc, const Files& files, const KnownMaps& maps) {
  const json& front = doc["material"]["front"];
  const double w = 10.0, h = 6.0;  // 200 x 120 px at 0.05 mm
  for (const char* key : {"basecolor", "normal"}) {
    const json& image = front[key]["texture"]["image"];
    const std::string path = image["path"];
    ASSERT_TRUE(files.contains(path)) << path;
    expect_image_consistent(image, decode(files.at(path)), w, h);
  }
  // Colour: the albedo as scanned (sRGB); normals: OpenGL, (n + 1) / 2.
  EXPECT_EQ(cv::norm(decode(files.at("albedo.png")), maps.albedo, cv::NORM_INF), 0.0);
  const cv::Mat normal = decode(files.at(front["normal"]["texture"]["image"]["path"]));
  EXPECT_EQ(cv::norm(normal, maps.normal, cv::NORM_INF), 0.0);
  // Displacement: offset + grey * factor (grey in [0, 1]) is the height in mm.
  const json& displacement = front["displacement"]["texture"];
  const std::string height_path = displacement["image"]["path"];
  const cv::Mat grey = decode(files.at(height_path));
  expect_image_consistent(displacement["image"], grey, w, h);
  cv::Mat mm;
  grey.convertTo(mm, CV_64F, displacement["factor"].get<double>() / 65535.0,
                 displacement["offset"].get<double>());
  cv::Mat truth;
  maps.height.convertTo(truth, CV_64F);
  EXPECT_LT(cv::norm(mm, truth, cv::NORM_INF), 1.01 * (maps.high - maps.low) / 65535.0 / 2);
  // The constants a renderer falls back on: near the textures' averages.
  EXPECT_NEAR(front["displacement"]["constant"].get<double>(), cv::mean(truth)[0], 1e-3);
  const json& preview = front["preview"];
  ASSERT_TRUE(files.contains(preview["path"]));
  const cv::Mat preview_pixels = decode(files.at(preview["path"]));
  EXPECT_NEAR(preview["dpi"]["x"].get<double>() * preview["width"].get<double>() / 25.4,
              preview_pixels.cols, 1e-6);
  EXPECT_EQ(doc["schema"], "1.1");
}

TEST(U3mExport, FolderValidatesAndKeepsTheAdditionalRules) {
  TempDir dir("psrig-u3m");
  const KnownMaps maps = write_known_maps(dir / "maps");
  auto source = export_::material_source_from(maps.directory);
  ASSERT_TRUE(source);
  auto result = export_::export_material(*source, ExportFormat::u3m, dir / "knit");
  ASSERT_TRUE(result) << result.error().describe();
  const fs::path document = dir / "knit" / "knit.u3m";
  ASSERT_TRUE(fs::exists(document));
  std::ifstream in(document);
  const json doc = json::parse(in);
  Files files;
  for (const auto& entry : fs::directory_iterator(dir / "knit"))
    files[entry.path().filename().string()] = read_bytes(entry.path());
  check_document(doc, files, maps);
  EXPECT_EQ(doc["material"]["name"], "S-42");
  EXPECT_EQ(doc["material"]["created"], "2026-11-25T03:00:00Z");
  expect_schema_valid(document);
}

// A .u3ma read as the spec describes it, every restriction checked.
Files read_u3ma_strictly(const std::vector<unsigned char>& zip) {
  const auto u16 = [&](std::size_t at) { return zip[at] | (zip[at + 1] << 8); };
  const auto u32 = [&](std::size_t at) {
    return static_cast<std::uint32_t>(u16(at)) | (static_cast<std::uint32_t>(u16(at + 2)) << 16);
  };
  Files files;
  EXPECT_GE(zip.size(), 22u);
  const std::size_t end = zip.size() - 22;  // no archive comment: the record ends the file
  EXPECT_EQ(u32(end), 0x06054b50u);
  EXPECT_EQ(u16(end + 4), 0);
  EXPECT_EQ(u16(end + 6), 0);
  const int entries = u16(end + 10);
  EXPECT_EQ(u16(end + 8), entries);
  const std::size_t directory_size = u32(end + 12);
  std::size_t at = u32(end + 16);
  EXPECT_EQ(at + directory_size, end);  // nothing between the directory and its end record
  EXPECT_EQ(u16(end + 20), 0);
  std::size_t expected_local = 0;  // entries back to back from byte 0
  std::set<std::string> names;
  for (int i = 0; i < entries; ++i) {
    EXPECT_EQ(u32(at), 0x02014b50u);
    EXPECT_EQ(u16(at + 4), 0x003F) << "version made by";
    EXPECT_EQ(u16(at + 6), 0x14) << "version needed";
    const int flags = u16(at + 8);
    EXPECT_TRUE(flags & (1 << 11)) << "EFS (UTF-8) must be set";
    EXPECT_EQ(flags & ~((1 << 11) | 6), 0) << "only bits 1, 2 and 11 may be set";
    const int method = u16(at + 10);
    EXPECT_TRUE(method == 0 || method == 8);
    const std::uint32_t crc = u32(at + 16), packed = u32(at + 20), size = u32(at + 24);
    if (method == 0) {
      EXPECT_EQ(packed, size);
    }
    const int name_length = u16(at + 28);
    EXPECT_EQ(u16(at + 30), 0) << "extra field";
    EXPECT_EQ(u16(at + 32), 0) << "comment";
    EXPECT_EQ(u16(at + 34), 0) << "disk";
    EXPECT_EQ(u16(at + 36), 0) << "internal attributes";
    EXPECT_EQ(u32(at + 38), 0u) << "external attributes";
    const std::size_t local = u32(at + 42);
    const std::string name(zip.begin() + at + 46, zip.begin() + at + 46 + name_length);
    EXPECT_FALSE(name.empty());
    EXPECT_NE(name.front(), '/');
    EXPECT_TRUE(names.insert(name).second) << "duplicate " << name;
    // The local header repeats the central one.
    EXPECT_EQ(local, expected_local) << name;
    EXPECT_EQ(u32(local), 0x04034b50u);
    EXPECT_EQ(u16(local + 4), 0x14);
    EXPECT_EQ(u16(local + 6), flags);
    EXPECT_EQ(u16(local + 8), method);
    EXPECT_EQ(u32(local + 10), u32(at + 12)) << "time and date";
    EXPECT_EQ(u32(local + 14), crc);
    EXPECT_EQ(u32(local + 18), packed);
    EXPECT_EQ(u32(local + 22), size);
    EXPECT_EQ(u16(local + 26), name_length);
    EXPECT_EQ(u16(local + 28), 0) << "local extra field";
    const std::size_t data = local + 30 + name_length;
    std::vector<unsigned char> bytes(size);
    if (method == 0) {
      std::memcpy(bytes.data(), zip.data() + data, size);
    } else {
      z_stream z{};
      inflateInit2(&z, -MAX_WBITS);
      z.next_in = const_cast<unsigned char*>(zip.data() + data);
      z.avail_in = packed;
      z.next_out = bytes.data();
      z.avail_out = size;
      EXPECT_EQ(inflate(&z, Z_FINISH), Z_STREAM_END) << name;
      inflateEnd(&z);
    }
    EXPECT_EQ(crc32(0, bytes.data(), size), crc) << name;
    files[name] = std::move(bytes);
    expected_local = data + packed;  // no data descriptor follows
    at += 46 + name_length;
  }
  EXPECT_EQ(expected_local, u32(end + 16));
  return files;
}

TEST(U3mExport, ArchiveKeepsTheContainerRestrictions) {
  TempDir dir("psrig-u3m");
  const KnownMaps maps = write_known_maps(dir / "maps");
  auto source = export_::material_source_from(maps.directory);
  ASSERT_TRUE(source);
  auto result = export_::export_material(*source, ExportFormat::u3ma, dir / "knit.u3ma", {true});
  ASSERT_TRUE(result) << result.error().describe();
  EXPECT_EQ(list_directory(dir.path()), (std::vector<std::string>{"knit.u3ma", "maps"}));
  const Files files = read_u3ma_strictly(read_bytes(dir / "knit.u3ma"));
  ASSERT_TRUE(files.contains("knit.u3m"));
  EXPECT_TRUE(files.contains("normal_directx.png"));
  const auto& text = files.at("knit.u3m");
  const json doc = json::parse(text.begin(), text.end());
  check_document(doc, files, maps);
  // DirectX's normal map: green mirrored.
  EXPECT_EQ(cv::norm(decode(files.at("normal_directx.png")),
                     formats::flip_normal_green(maps.normal), cv::NORM_INF),
            0.0);
  std::ofstream(dir / "from-archive.u3m", std::ios::binary)
      .write(reinterpret_cast<const char*>(text.data()), static_cast<std::streamsize>(text.size()));
  expect_schema_valid(dir / "from-archive.u3m");
}

TEST(U3mExport, WithoutPixelSizeStillValidInPixels) {
  TempDir dir("psrig-u3m");
  write_known_maps(dir / "maps", {.pixel_size_mm = std::nullopt});
  auto source = export_::material_source_from(dir / "maps");
  ASSERT_TRUE(source);
  EXPECT_FALSE(source->warnings.empty());
  auto result = export_::export_material(*source, ExportFormat::u3m, dir / "px");
  ASSERT_TRUE(result) << result.error().describe();
  std::ifstream in(dir / "px" / "px.u3m");
  const json doc = json::parse(in);
  const json& image = doc["material"]["front"]["basecolor"]["texture"]["image"];
  EXPECT_EQ(image["width"], 200.0);  // one pixel written as 1 mm
  EXPECT_NEAR(image["dpi"]["x"].get<double>(), 25.4, 1e-9);
  expect_schema_valid(dir / "px" / "px.u3m");
}

TEST(U3mExport, UnwritableArchiveFailsAndLeavesNothing) {
  TempDir dir("psrig-u3m");
  write_known_maps(dir / "maps");
  auto source = export_::material_source_from(dir / "maps");
  ASSERT_TRUE(source);
  auto result =
      export_::export_material(*source, ExportFormat::u3ma, "/proc/psrig-export-test.u3ma");
  ASSERT_FALSE(result);
  EXPECT_FALSE(fs::exists("/proc/psrig-export-test.u3ma"));
}

}  // namespace
}  // namespace psrig::test
