#include "psrig/export/gltf_export.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>
#include <tiny_gltf.h>

#include <nlohmann/json.hpp>

#include "export_target.h"
#include "package_files.h"
#include "psrig/export/occlusion.h"
#include "psrig/formats/atomic_directory.h"
#include "texture_set.h"

namespace psrig::export_ {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

tinygltf::Value to_value(const json& j) {
  if (j.is_object()) {
    tinygltf::Value::Object o;
    for (const auto& [k, v] : j.items())
      o[k] = to_value(v);
    return tinygltf::Value(std::move(o));
  }
  if (j.is_array()) {
    tinygltf::Value::Array a;
    for (const auto& v : j)
      a.push_back(to_value(v));
    return tinygltf::Value(std::move(a));
  }
  if (j.is_boolean()) return tinygltf::Value(j.get<bool>());
  if (j.is_number_integer()) return tinygltf::Value(j.get<int>());
  if (j.is_number()) return tinygltf::Value(j.get<double>());
  if (j.is_string()) return tinygltf::Value(j.get<std::string>());
  return {};
}

template <typename T>
std::size_t append(std::vector<unsigned char>& buffer, const std::vector<T>& values) {
  while (buffer.size() % 4 != 0)
    buffer.push_back(0);
  const std::size_t at = buffer.size();
  buffer.resize(at + values.size() * sizeof(T));
  std::memcpy(buffer.data() + at, values.data(), values.size() * sizeof(T));
  return at;
}

int add_view(tinygltf::Model& model, std::size_t offset, std::size_t length, int target) {
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = offset;
  view.byteLength = length;
  view.target = target;
  model.bufferViews.push_back(view);
  return static_cast<int>(model.bufferViews.size()) - 1;
}

int add_accessor(tinygltf::Model& model, int view, int component, std::size_t count, int type,
                 std::vector<double> min = {}, std::vector<double> max = {}) {
  tinygltf::Accessor a;
  a.bufferView = view;
  a.componentType = component;
  a.count = count;
  a.type = type;
  a.minValues = std::move(min);
  a.maxValues = std::move(max);
  model.accessors.push_back(a);
  return static_cast<int>(model.accessors.size()) - 1;
}

// KHR_texture_transform: the texture repeated `repeats` times over the quad.
tinygltf::ExtensionMap repeat_transform(int repeats) {
  tinygltf::Value::Object transform;
  transform["offset"] =
      tinygltf::Value(tinygltf::Value::Array{tinygltf::Value(0.0), tinygltf::Value(0.0)});
  transform["scale"] =
      tinygltf::Value(tinygltf::Value::Array{tinygltf::Value(static_cast<double>(repeats)),
                                             tinygltf::Value(static_cast<double>(repeats))});
  return {{"KHR_texture_transform", tinygltf::Value(std::move(transform))}};
}

// Where the export goes, checked before any map is read.
struct Target {
  fs::path out;
  fs::path parent;   // the directory it is made in
  std::string stem;  // the file names' stem
  // How a directory export treats an existing `out`; none for a .glb.
  std::optional<formats::AtomicDirectory::Existing> existing;
};

Result<Target> check_target(const fs::path& out, const GltfOptions& options) {
  if (options.repeats < 1) return std::unexpected(bad_input({}, "--repeat", "must be 1 or more"));
  std::error_code ec;
  Target target{out, {}, out.stem().string(), std::nullopt};
  if (options.binary && fs::is_directory(out, ec))
    return std::unexpected(bad_input(out, "--out", "is a directory; name the .glb file"));
  if (!options.binary) {
    auto checked = check_directory_target(out, target.stem + ".gltf");
    if (!checked) return std::unexpected(checked.error());
    target.existing = *checked;
  }
  target.parent = out.has_parent_path() ? out.parent_path() : fs::path(".");
  if (!fs::is_directory(target.parent, ec))
    return std::unexpected(bad_input(out, "--out", "its directory does not exist; make it first"));
  return target;
}

// The textures the material carries, as PNGs; the occlusion only with a
// height map to derive it from.
struct MaterialPngs {
  std::vector<unsigned char> albedo, normal, occlusion;
};

// Ambient occlusion from the height map (occlusion.h): the crevices
// between loops and yarns darken under ambient light. Radius: half a
// millimetre, about a yarn, in 4 to 32 pixels.
Result<std::vector<unsigned char>> occlusion_png(const MaterialSource& source,
                                                 const TextureSet& textures) {
  cv::Mat height;
  textures.height.convertTo(height, CV_32F, (textures.height_high - textures.height_low) / 65535.0,
                            textures.height_low);
  const int radius =
      source.pixel_size_mm
          ? std::clamp(static_cast<int>(std::lround(0.5 / *source.pixel_size_mm)), 4, 32)
          : 16;
  cv::Mat ao8;
  ambient_occlusion(height, source.pixel_size_mm.value_or(1.0), radius)
      .convertTo(ao8, CV_8U, 255.0);
  return encode_png(ao8, texture_metadata(source, textures, TextureKind::occlusion));
}

Result<MaterialPngs> encode_material_pngs(const MaterialSource& source,
                                          const TextureSet& textures) {
  // glTF viewers read 8-bit textures everywhere; 16-bit normals stay in the
  // maps directory and the U3M export.
  auto albedo =
      encode_png(textures.albedo, texture_metadata(source, textures, TextureKind::albedo));
  if (!albedo) return std::unexpected(albedo.error());
  auto normal =
      encode_png(to_8bit(textures.normal), texture_metadata(source, textures, TextureKind::normal));
  if (!normal) return std::unexpected(normal.error());
  MaterialPngs pngs{std::move(*albedo), std::move(*normal), {}};
  if (!textures.height.empty()) {
    auto occlusion = occlusion_png(source, textures);
    if (!occlusion) return std::unexpected(occlusion.error());
    pngs.occlusion = std::move(*occlusion);
  }
  return pngs;
}

// What extras.psrig says of the material: its size, units and provenance.
json describe_material(const MaterialSource& source, const ExportResult& result,
                       const GltfOptions& options) {
  return {{"units", source.pixel_size_mm ? "mm" : "px (no pixel size: 1 px written as 1 mm)"},
          {"width_mm", result.width_mm},
          {"height_mm", result.height_mm},
          {"width_px", source.width_px},
          {"height_px", source.height_px},
          {"pixel_size_mm", source.pixel_size_mm ? json(*source.pixel_size_mm) : json()},
          {"repeats", options.repeats},
          {"seamless_tile", source.tile},
          {"sample_id", source.sample_id.empty() ? json() : json(source.sample_id)},
          {"scan_time", source.scan_time.empty() ? json() : json(source.scan_time)},
          {"normal_convention", "OpenGL (+Y up), as glTF"},
          {"roughness", "not measured: 0.8, a matte fabric's starting point"},
          {"occlusion",
           "derived from the height map: horizon-based ambient occlusion "
           "(Bavoil et al. 2008), 8 directions, radius 0.5 mm"}};
}

using BesideFiles = std::vector<std::pair<fs::path, std::vector<unsigned char>>>;

// The maps glTF has no place for, as files beside it (in the directory, or
// beside the .glb as STEM_NAME.png), each described in `psrig`.
Result<BesideFiles> beside_files(const MaterialSource& source, const TextureSet& textures,
                                 const GltfOptions& options, const std::string& stem, json& psrig) {
  BesideFiles beside;
  if (!textures.height.empty()) {
    auto height_png =
        encode_png(textures.height, texture_metadata(source, textures, TextureKind::height));
    if (!height_png) return std::unexpected(height_png.error());
    const std::string name = (options.binary ? stem + "_" : std::string()) + package_files::kHeight;
    beside.emplace_back(name, std::move(*height_png));
    psrig["height"] = {{"uri", name},
                       {"note",
                        "glTF 2.0 has no displacement map; this 16-bit grey PNG holds the height: "
                        "grey 0 is `low`, 65535 is `high`"},
                       {"low", textures.height_low},
                       {"high", textures.height_high},
                       {"units", source.height_units}};
  }
  if (options.directx_normal) {
    auto dx = encode_png(to_directx(textures.normal),
                         texture_metadata(source, textures, TextureKind::normal_directx));
    if (!dx) return std::unexpected(dx.error());
    const std::string name =
        (options.binary ? stem + "_" : std::string()) + package_files::kNormalDirectx;
    beside.emplace_back(name, std::move(*dx));
    psrig["normal_directx"] = {{"uri", name},
                               {"note",
                                "the normal map with green flipped (DirectX, +Y down), for "
                                "Substance and Unreal; glTF itself uses the OpenGL one"}};
  }
  return beside;
}

// The quad in the XY plane, facing +Z, centred, `w` by `h` metres; the
// image's top-left at UV (0, 0) (glTF's origin), so the image's up is +Y as
// the normal map's. Its attributes and indices go into buffer 0.
tinygltf::Primitive add_quad(tinygltf::Model& model, float w, float h) {
  auto& bin = model.buffers[0].data;
  const std::vector<float> positions = {-w / 2, h / 2,  0, w / 2,  h / 2,  0,
                                        w / 2,  -h / 2, 0, -w / 2, -h / 2, 0};
  const std::vector<float> normals = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
  // Tangents along +U (+X); w = 1: the bitangent N x T = +Y is the image's
  // up, the normal map's +Y. Given, so no viewer has to generate its own.
  const std::vector<float> tangents = {1, 0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1};
  const std::vector<float> uvs = {0, 0, 1, 0, 1, 1, 0, 1};
  const std::vector<std::uint16_t> indices = {0, 3, 2, 0, 2, 1};  // counter-clockwise seen from +Z
  const int position_view =
      add_view(model, append(bin, positions), positions.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER);
  const int normal_view =
      add_view(model, append(bin, normals), normals.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER);
  const int tangent_view =
      add_view(model, append(bin, tangents), tangents.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER);
  const int uv_view =
      add_view(model, append(bin, uvs), uvs.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER);
  const int index_view = add_view(model, append(bin, indices), indices.size() * 2,
                                  TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
  tinygltf::Primitive primitive;
  primitive.attributes["POSITION"] =
      add_accessor(model, position_view, TINYGLTF_COMPONENT_TYPE_FLOAT, 4, TINYGLTF_TYPE_VEC3,
                   {-w / 2, -h / 2, 0}, {w / 2, h / 2, 0});
  primitive.attributes["NORMAL"] =
      add_accessor(model, normal_view, TINYGLTF_COMPONENT_TYPE_FLOAT, 4, TINYGLTF_TYPE_VEC3);
  primitive.attributes["TANGENT"] =
      add_accessor(model, tangent_view, TINYGLTF_COMPONENT_TYPE_FLOAT, 4, TINYGLTF_TYPE_VEC4);
  primitive.attributes["TEXCOORD_0"] =
      add_accessor(model, uv_view, TINYGLTF_COMPONENT_TYPE_FLOAT, 4, TINYGLTF_TYPE_VEC2);
  primitive.indices = add_accessor(model, index_view, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, 6,
                                   TINYGLTF_TYPE_SCALAR);
  primitive.mode = TINYGLTF_MODE_TRIANGLES;
  primitive.material = 0;
  return primitive;
}

// The one sampler every texture uses: mipmapped, repeating.
void add_sampler(tinygltf::Model& model) {
  tinygltf::Sampler sampler;
  sampler.magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
  sampler.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_LINEAR;
  sampler.wrapS = TINYGLTF_TEXTURE_WRAP_REPEAT;
  sampler.wrapT = TINYGLTF_TEXTURE_WRAP_REPEAT;
  model.samplers.push_back(sampler);
}

// A texture and its image: inside the .glb (`binary`), or the file `file`
// beside the .gltf. Returns the texture's index.
int add_texture(tinygltf::Model& model, const std::string& name, const char* file,
                const std::vector<unsigned char>& png, bool binary) {
  tinygltf::Image image;
  image.name = name;
  image.mimeType = "image/png";
  if (binary)
    image.bufferView = add_view(model, append(model.buffers[0].data, png), png.size(), 0);
  else
    image.uri = file;
  model.images.push_back(image);
  tinygltf::Texture texture;
  texture.sampler = 0;
  texture.source = static_cast<int>(model.images.size()) - 1;
  model.textures.push_back(texture);
  return static_cast<int>(model.textures.size()) - 1;
}

// The cloth's material: its textures repeated over the quad, and sheen.
tinygltf::Material make_material(tinygltf::Model& model, const MaterialSource& source,
                                 const TextureSet& textures, const MaterialPngs& pngs,
                                 const GltfOptions& options) {
  tinygltf::Material material;
  material.name = source.sample_id.empty() ? "psrig scan" : source.sample_id;
  material.doubleSided = true;  // cloth is seen from both sides
  material.pbrMetallicRoughness.baseColorTexture.index =
      add_texture(model, "albedo", package_files::kAlbedo, pngs.albedo, options.binary);
  material.pbrMetallicRoughness.baseColorTexture.extensions = repeat_transform(options.repeats);
  material.pbrMetallicRoughness.metallicFactor = 0.0;
  // Not measured (photometric stereo assumes a matte surface): a matte
  // fabric's usual starting point, for the artist to tune.
  material.pbrMetallicRoughness.roughnessFactor = 0.8;
  material.normalTexture.index = add_texture(model, "normal", package_files::kNormal, pngs.normal, options.binary);
  material.normalTexture.extensions = repeat_transform(options.repeats);
  if (!textures.height.empty()) {
    material.occlusionTexture.index =
        add_texture(model, "occlusion", package_files::kOcclusion, pngs.occlusion, options.binary);
    material.occlusionTexture.extensions = repeat_transform(options.repeats);
  }
  // KHR_materials_sheen: the retro-reflective rim of fibres. Its colour
  // starts at the fabric's mean colour (linear), a convention, not a
  // measurement.
  tinygltf::Value::Object sheen;
  const cv::Vec3d mean = textures.mean_linear_rgb;
  sheen["sheenColorFactor"] = tinygltf::Value(tinygltf::Value::Array{
      tinygltf::Value(mean[0]), tinygltf::Value(mean[1]), tinygltf::Value(mean[2])});
  sheen["sheenRoughnessFactor"] = tinygltf::Value(0.5);
  material.extensions["KHR_materials_sheen"] = tinygltf::Value(std::move(sheen));
  return material;
}

// The whole model: the quad, named after its material, alone in the scene.
tinygltf::Model make_model(const MaterialSource& source, const TextureSet& textures,
                           const MaterialPngs& pngs, const json& psrig, const ExportResult& result,
                           const GltfOptions& options) {
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "psrig";
  model.buffers.emplace_back();
  const float w = static_cast<float>(result.width_mm * options.repeats / 1000.0);
  const float h = static_cast<float>(result.height_mm * options.repeats / 1000.0);
  const tinygltf::Primitive primitive = add_quad(model, w, h);
  add_sampler(model);
  tinygltf::Material material = make_material(model, source, textures, pngs, options);
  material.extras = to_value(json{{"psrig", psrig}});
  model.materials.push_back(material);
  model.asset.extras = to_value(json{{"psrig", psrig}});

  tinygltf::Mesh mesh;
  mesh.name = material.name;
  mesh.primitives.push_back(primitive);
  model.meshes.push_back(mesh);
  tinygltf::Node node;
  node.mesh = 0;
  node.name = material.name;
  model.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.nodes = {0};
  model.scenes.push_back(scene);
  model.defaultScene = 0;
  model.extensionsUsed = {"KHR_materials_sheen", "KHR_texture_transform"};
  return model;
}

// The .glb and the files beside it, each whole or not at all; the files
// beside go again when the .glb cannot be written.
Status write_glb(const tinygltf::Model& model, const BesideFiles& beside, const Target& target,
                 ExportResult& result) {
  tinygltf::TinyGLTF writer;
  writer.SetImageWriter(nullptr, nullptr);  // the PNGs are ours, with their metadata
  std::ostringstream stream;
  if (!writer.WriteGltfSceneToStream(&model, stream, false, true))
    return std::unexpected(internal_error("tinygltf could not serialise the model"));
  const std::string glb = stream.str();
  for (const auto& [name, bytes] : beside) {
    if (auto ok = write_file_atomically(target.parent / name, bytes); !ok)
      return std::unexpected(ok.error());
    result.beside.push_back(target.parent / name);
  }
  if (auto ok =
          write_file_atomically(target.out, std::vector<unsigned char>(glb.begin(), glb.end()));
      !ok) {
    std::error_code ec;
    for (const auto& file : result.beside)
      fs::remove(file, ec);
    return std::unexpected(ok.error());
  }
  return {};
}

// The .gltf, its buffer and its textures in a directory that appears whole
// or not at all.
Status write_gltf_directory(tinygltf::Model& model, const MaterialPngs& pngs,
                            const BesideFiles& beside, const Target& target) {
  auto staging = formats::AtomicDirectory::create(target.out);
  if (!staging)
    return std::unexpected(
        io_error(target.out, "cannot make the export here: " + staging.error().message));
  const fs::path dir = staging->path();
  model.buffers[0].uri = target.stem + ".bin";
  if (auto ok = write_bytes(dir / package_files::kAlbedo, pngs.albedo); !ok)
    return std::unexpected(ok.error());
  if (auto ok = write_bytes(dir / package_files::kNormal, pngs.normal); !ok)
    return std::unexpected(ok.error());
  if (!pngs.occlusion.empty())
    if (auto ok = write_bytes(dir / package_files::kOcclusion, pngs.occlusion); !ok)
      return std::unexpected(ok.error());
  for (const auto& [name, bytes] : beside)
    if (auto ok = write_bytes(dir / name, bytes); !ok) return std::unexpected(ok.error());
  tinygltf::TinyGLTF writer;
  writer.SetImageWriter(nullptr, nullptr);  // the PNGs are ours, with their metadata
  const fs::path gltf = dir / (target.stem + ".gltf");
  if (!writer.WriteGltfSceneToFile(&model, gltf.string(), false, false, true, false))
    return std::unexpected(io_error(gltf, "cannot write the glTF"));
  return staging->commit(*target.existing, false);
}

}  // namespace

ExportResult export_result(const MaterialSource& source, const fs::path& out) {
  ExportResult result;
  result.output = out;
  result.width_mm = source.width_mm();
  result.height_mm = source.height_mm();
  result.warnings = source.warnings;
  return result;
}

Result<ExportResult> export_gltf(const MaterialSource& source, const fs::path& out,
                                 const GltfOptions& options) {
  auto target = check_target(out, options);
  if (!target) return std::unexpected(target.error());
  auto textures = load_textures(source);
  if (!textures) return std::unexpected(textures.error());

  ExportResult result = export_result(source, out);

  auto pngs = encode_material_pngs(source, *textures);
  if (!pngs) return std::unexpected(pngs.error());
  json psrig = describe_material(source, result, options);
  auto beside = beside_files(source, *textures, options, target->stem, psrig);
  if (!beside) return std::unexpected(beside.error());
  tinygltf::Model model = make_model(source, *textures, *pngs, psrig, result, options);

  const Status written = options.binary ? write_glb(model, *beside, *target, result)
                                        : write_gltf_directory(model, *pngs, *beside, *target);
  if (!written) return std::unexpected(written.error());
  return result;
}

}  // namespace psrig::export_
