// The woven data set file, `psrig-woven-dataset/1`. Little-endian; u32 and
// u64 unsigned integers, f32 IEEE-754 floats; a text is a u32 byte count
// then that many UTF-8 bytes (no terminator).
//
//   magic      22 bytes  "psrig-woven-dataset/1\n"
//   seed       u64
//   command    text
//   materials  u32 count M, then M times:
//     pattern                text
//     texture_size T         u32 (1 to 4096)
//     roughness, height_scale, twist_deg, inclination_deg   4 x f32
//     normal                 T*T*3 f32 (row-major texels, xyz each)
//     orientation            T*T*3 f32
//   queries    u64 count Q, then Q records of 56 bytes each:
//     material u32; u, v, size f32; wi xyz, wo xyz 6 x f32;
//     c_warp, c_weft, s_warp, s_weft 4 x f32
//
// The file ends right after the last query: the reader checks Q * 56
// against the bytes left before reading any, so a truncated or padded file
// is refused with what it holds and what it should.

#include "psrig/cloth/woven_dataset.h"

#include <cmath>
#include <fmt/format.h>

#include "binary_file.h"

namespace psrig::cloth {
namespace {

constexpr std::string_view dataset_magic = "psrig-woven-dataset/1\n";
constexpr std::size_t query_record_bytes = 4 + 13 * 4;
constexpr std::uint32_t largest_texture = 4096;

void write_query(binary::Writer& out, const WovenQuery& query) {
  out.u32(query.material);
  for (float value :
       {query.u, query.v, query.size, query.wi[0], query.wi[1], query.wi[2], query.wo[0],
        query.wo[1], query.wo[2], query.c_warp, query.c_weft, query.s_warp, query.s_weft}) {
    out.f32(value);
  }
}

Result<WovenMaterialSample> read_material(binary::Reader& in, std::size_t index) {
  const std::string which = fmt::format("material {}", index);
  WovenMaterialSample material;
  auto pattern = in.text(which + "'s pattern name");
  auto size = pattern ? in.u32(which + "'s texture size") : std::unexpected(pattern.error());
  if (!size) {
    return std::unexpected(size.error());
  }
  if (*size == 0 || *size > largest_texture) {
    return std::unexpected(in.fail(
        fmt::format("{}'s texture size is {}, not 1 to {}", which, *size, largest_texture)));
  }
  material.pattern = std::move(*pattern);
  material.texture_size = static_cast<int>(*size);
  for (float* field : {&material.roughness, &material.height_scale, &material.twist_deg,
                       &material.inclination_deg}) {
    auto value = in.f32(which + "'s parameters");
    if (!value) {
      return std::unexpected(value.error());
    }
    *field = *value;
  }
  const std::uint64_t floats = std::uint64_t{*size} * *size * 3;
  auto normal = in.floats(floats, which + "'s normal texture");
  auto orientation = normal ? in.floats(floats, which + "'s orientation texture")
                            : std::unexpected(normal.error());
  if (!orientation) {
    return std::unexpected(orientation.error());
  }
  material.normal = std::move(*normal);
  material.orientation = std::move(*orientation);
  return material;
}

Result<WovenQuery> read_query(binary::Reader& in, std::uint64_t index, std::size_t materials) {
  WovenQuery query;
  std::array<float, 13> values{};
  auto material = in.u32("a query");
  if (!material) {
    return std::unexpected(material.error());
  }
  if (auto ok = in.raw(values.data(), sizeof values, "a query"); !ok) {
    return std::unexpected(ok.error());
  }
  if (*material >= materials) {
    return std::unexpected(
        in.fail(fmt::format("query {} names material {} of {}", index, *material, materials)));
  }
  for (float value : values) {
    if (!std::isfinite(value)) {
      return std::unexpected(
          in.fail(fmt::format("query {} holds a value that is not finite", index)));
    }
  }
  query.material = *material;
  query.u = values[0];
  query.v = values[1];
  query.size = values[2];
  query.wi = {values[3], values[4], values[5]};
  query.wo = {values[6], values[7], values[8]};
  query.c_warp = values[9];
  query.c_weft = values[10];
  query.s_warp = values[11];
  query.s_weft = values[12];
  return query;
}

}  // namespace

Status write_woven_dataset(const std::filesystem::path& file, const WovenDataset& dataset) {
  binary::Writer out;
  out.bytes(dataset_magic.data(), dataset_magic.size());
  out.u64(dataset.seed);
  out.text(dataset.command);
  out.u32(static_cast<std::uint32_t>(dataset.materials.size()));
  for (std::size_t m = 0; m < dataset.materials.size(); ++m) {
    const WovenMaterialSample& material = dataset.materials[m];
    const auto texels = static_cast<std::size_t>(material.texture_size) * material.texture_size * 3;
    if (material.texture_size <= 0 || material.texture_size > static_cast<int>(largest_texture) ||
        material.normal.size() != texels || material.orientation.size() != texels) {
      return std::unexpected(bad_input(
          file, "",
          fmt::format("material {} ({}): texture size {} but {} normal and {} orientation "
                      "floats (T*T*3 = {} each)",
                      m, material.pattern, material.texture_size, material.normal.size(),
                      material.orientation.size(), texels)));
    }
    out.text(material.pattern);
    out.u32(static_cast<std::uint32_t>(material.texture_size));
    for (float value : {material.roughness, material.height_scale, material.twist_deg,
                        material.inclination_deg}) {
      out.f32(value);
    }
    out.floats(material.normal);
    out.floats(material.orientation);
  }
  out.u64(dataset.queries.size());
  for (std::size_t q = 0; q < dataset.queries.size(); ++q) {
    if (dataset.queries[q].material >= dataset.materials.size()) {
      return std::unexpected(
          bad_input(file, "",
                    fmt::format("query {} names material {} of {}", q, dataset.queries[q].material,
                                dataset.materials.size())));
    }
    write_query(out, dataset.queries[q]);
  }
  return binary::write_file_atomically(file, out.buffer());
}

Result<WovenDataset> read_woven_dataset(const std::filesystem::path& file) {
  auto bytes = binary::read_whole_file(file);
  if (!bytes) {
    return std::unexpected(bytes.error());
  }
  binary::Reader in(file, *bytes);
  WovenDataset dataset;
  if (auto ok = in.expect_magic(dataset_magic); !ok) {
    return std::unexpected(ok.error());
  }
  auto seed = in.u64("the seed");
  auto command = seed ? in.text("the command") : std::unexpected(seed.error());
  auto materials = command ? in.u32("the material count") : std::unexpected(command.error());
  if (!materials) {
    return std::unexpected(materials.error());
  }
  dataset.seed = *seed;
  dataset.command = std::move(*command);
  for (std::uint32_t m = 0; m < *materials; ++m) {
    auto material = read_material(in, m);
    if (!material) {
      return std::unexpected(material.error());
    }
    dataset.materials.push_back(std::move(*material));
  }
  auto queries = in.u64("the query count");
  if (!queries) {
    return std::unexpected(queries.error());
  }
  if (in.left() / query_record_bytes != *queries || in.left() % query_record_bytes != 0) {
    return std::unexpected(
        in.fail(fmt::format("the file says {} queries ({} bytes) but {} bytes follow the count",
                            *queries, *queries * query_record_bytes, in.left())));
  }
  dataset.queries.reserve(*queries);
  for (std::uint64_t q = 0; q < *queries; ++q) {
    auto query = read_query(in, q, dataset.materials.size());
    if (!query) {
      return std::unexpected(query.error());
    }
    dataset.queries.push_back(*query);
  }
  return dataset;
}

}  // namespace psrig::cloth
