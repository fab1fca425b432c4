#include "psrig/preview/woven_far_cloth.h"

#include <GLES3/gl3.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>

#include "gl_program.h"
#include "grid_indices.h"
#include "psrig/preview/woven_decoder_pass.h"
#include "psrig/preview/yarn_shading.h"

namespace psrig::preview {
namespace {

constexpr int kWovenFloatsPerVertex = 11;  // position, (u, v), across, normal
// The encoder's textures (woven_neural_render_test encodes at the same size).
constexpr int kEncoderTexels = 64;

std::filesystem::path own_folder() {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::path() : self.parent_path();
}

WovenColours decoder_colours(const cloth::YarnColours& c, float irradiance) {
  const auto vec = [](const Eigen::Vector3f& v) { return cv::Vec3f(v.x(), v.y(), v.z()); };
  return {vec(c.warp_diffuse), vec(c.weft_diffuse), vec(c.warp_specular), vec(c.weft_specular),
          irradiance};
}

// What the encoder takes: a change in any of it re-runs the encoder.
bool same_encoding(const WovenFarMaterial& a, const WovenFarMaterial& b) {
  const cloth::YarnShape &sa = a.parameters.shape, &sb = b.parameters.shape;
  return a.weave.warps == b.weave.warps && a.weave.wefts == b.weave.wefts &&
         a.weave.cells == b.weave.cells && a.parameters.alpha == b.parameters.alpha &&
         a.parameters.beta == b.parameters.beta && sa.twist_deg == sb.twist_deg &&
         sa.inclination_deg == sb.inclination_deg && sa.gap_ratio == sb.gap_ratio &&
         sa.section_edge_deg == sb.section_edge_deg;
}

}  // namespace

WovenFarMaterial woven_far_material(const cloth::WeaveMatrix& weave,
                                    const Eigen::Vector3f& warp_colour,
                                    const Eigen::Vector3f& weft_colour) {
  WovenFarMaterial material;
  material.weave = weave;
  material.parameters = cloth::weave_parameters(weave);
  // The fabric model scatters once (cloth/README.md: the light the yarns
  // send into each other is lost); the near level's yarns scatter again
  // nearby (yarn_shading.h, huang2025 eq. 8: diffuse light times
  // 1 + s a / (1 - s a)), so a light yarn glows more than a dark one. The
  // same factor on k_d makes the two levels' colours agree.
  const float s = FibreShading{}.local_scattering;
  const auto scattered = [s](const Eigen::Vector3f& albedo) {
    return Eigen::Vector3f(albedo.array() / (1 - s * albedo.array()).max(0.05F));
  };
  material.colours.warp_diffuse = scattered(warp_colour);
  material.colours.weft_diffuse = scattered(weft_colour);
  material.colours.warp_specular = material.colours.weft_specular =
      Eigen::Vector3f::Constant(kWovenFarSpecular);
  return material;
}

std::filesystem::path find_woven_weights() {
  std::error_code ec;
  if (const std::filesystem::path folder = own_folder(); !folder.empty()) {
    const auto installed = folder / ".." / "share" / "psrig" / "woven" / "woven.wnn";
    if (std::filesystem::is_regular_file(installed, ec))
      return std::filesystem::weakly_canonical(installed, ec);
  }
  return PSRIG_SOURCE_WOVEN_WEIGHTS;
}

struct WovenFarCloth::Gl {
  std::unique_ptr<WovenDecoderPass> decoder;
  std::optional<GlProgram> composite;
  GLuint array = 0, vertices = 0, indices = 0;
  GLuint empty_array = 0;  // the composite's full-screen triangle
  // The decoded pixels: sRGB-stored RGBA (8 bits a channel, as the frame).
  GLuint framebuffer = 0, decoded = 0;
  cv::Size decoded_size;
  ~Gl() {
    glDeleteBuffers(1, &vertices);
    glDeleteBuffers(1, &indices);
    glDeleteVertexArrays(1, &array);
    glDeleteVertexArrays(1, &empty_array);
    glDeleteFramebuffers(1, &framebuffer);
    glDeleteTextures(1, &decoded);
  }
};

Result<std::unique_ptr<WovenFarCloth>> WovenFarCloth::create(
    std::shared_ptr<const cloth::WovenNetwork> network) {
  std::unique_ptr<WovenFarCloth> cloth(new WovenFarCloth);
  cloth->network_ = std::move(network);
  cloth->gl_ = std::make_unique<Gl>();
  Gl& gl = *cloth->gl_;
  auto decoder = WovenDecoderPass::create(*cloth->network_, WovenWeightStorage::texture,
                                          WovenQuerySource::mesh);
  if (!decoder) return std::unexpected(decoder.error());
  gl.decoder = std::move(*decoder);
  auto composite = GlProgram::build(shaders::woven_decoder_vert, shaders::woven_composite_frag);
  if (!composite) return std::unexpected(composite.error());
  gl.composite = std::move(*composite);
  glGenVertexArrays(1, &gl.array);
  glGenVertexArrays(1, &gl.empty_array);
  glGenBuffers(1, &gl.vertices);
  glGenBuffers(1, &gl.indices);
  glGenFramebuffers(1, &gl.framebuffer);
  glGenTextures(1, &gl.decoded);
  return cloth;
}

WovenFarCloth::~WovenFarCloth() = default;

Status WovenFarCloth::set_material(const WovenFarMaterial& material) {
  if (!material_set_ || !same_encoding(material, material_)) {
    auto sample =
        cloth::generate_woven_material(material.weave, material.parameters, kEncoderTexels);
    if (!sample) return std::unexpected(sample.error());
    auto prepared = network_->prepare(*sample);
    if (!prepared) return std::unexpected(prepared.error());
    gl_->decoder->set_material(*prepared);
    ++encodes_;
  }
  material_ = material;
  material_set_ = true;
  return {};
}

void WovenFarCloth::update(const cloth::YarnSurface& surface) {
  const cloth::StitchMesh& mesh = surface.mesh;
  Gl& gl = *gl_;
  vertices_.resize(static_cast<std::size_t>((mesh.columns + 1) * (mesh.rows + 1)) *
                   kWovenFloatsPerVertex);
  std::size_t at = 0;
  const auto vertex = [&](int column, int row) {
    return mesh.vertex(std::clamp(column, 0, mesh.columns), std::clamp(row, 0, mesh.rows));
  };
  for (int row = 0; row <= mesh.rows; ++row)
    for (int column = 0; column <= mesh.columns; ++column) {
      const Eigen::Vector3f& p = mesh.vertex(column, row);
      // The cloth's frame from the neighbours: along the wefts (columns
      // are warps) and the front.
      const Eigen::Vector3f across = vertex(column + 1, row) - vertex(column - 1, row);
      const Eigen::Vector3f up = vertex(column, row + 1) - vertex(column, row - 1);
      const Eigen::Vector3f normal = across.cross(up).normalized();
      const Eigen::Vector3f along_weft = across.normalized();
      // Face coordinates over the whole repeat from the mesh's first face:
      // the weave's phase as the yarns have it.
      for (const float value :
           {p.x(), p.y(), p.z(),
            static_cast<float>(column) / static_cast<float>(surface.repeat_columns),
            static_cast<float>(row) / static_cast<float>(surface.repeat_rows), along_weft.x(),
            along_weft.y(), along_weft.z(), normal.x(), normal.y(), normal.z()})
        vertices_[at++] = value;
    }
  glBindVertexArray(gl.array);
  glBindBuffer(GL_ARRAY_BUFFER, gl.vertices);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices_.size() * sizeof(float)),
               vertices_.data(), GL_DYNAMIC_DRAW);
  constexpr GLsizei stride = kWovenFloatsPerVertex * sizeof(float);
  const auto offset = [](int floats) {
    return reinterpret_cast<const void*>(static_cast<std::size_t>(floats) * sizeof(float));
  };
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, offset(0));
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 2, GL_FLOAT, GL_FALSE, stride, offset(3));
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, stride, offset(5));
  glEnableVertexAttribArray(3);
  glVertexAttribPointer(3, 3, GL_FLOAT, GL_FALSE, stride, offset(8));
  if (mesh.columns != columns_ || mesh.rows != rows_) {
    columns_ = mesh.columns;
    rows_ = mesh.rows;
    index_count_ = upload_grid_indices(gl.indices, columns_, rows_);
  }
  glBindVertexArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
}

void WovenFarCloth::draw(const KnitFrame& frame, const WovenFarDraw& how) const {
  if (!ready()) return;
  Gl& gl = *gl_;
  const float scale = std::max(how.decode_scale, 1.0F);
  const cv::Size size(
      std::max(1, static_cast<int>(std::ceil(static_cast<float>(how.viewport.width) / scale))),
      std::max(1, static_cast<int>(std::ceil(static_cast<float>(how.viewport.height) / scale))));
  if (size != gl.decoded_size) {
    glBindTexture(GL_TEXTURE_2D, gl.decoded);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_SRGB8_ALPHA8, size.width, size.height, 0, GL_RGBA,
                 GL_UNSIGNED_BYTE, nullptr);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glBindTexture(GL_TEXTURE_2D, 0);
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, gl.framebuffer);
    glFramebufferTexture2D(GL_DRAW_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, gl.decoded, 0);
    gl.decoded_size = size;
  }

  // The decode: the mesh's pixels only, each once (no multisampling).
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, gl.framebuffer);
  glViewport(0, 0, size.width, size.height);
  glClearColor(0, 0, 0, 0);
  glClear(GL_COLOR_BUFFER_BIT);
  const WovenDecoderPass& decoder = *gl.decoder;
  decoder.use(decoder_colours(material_.colours, how.irradiance));
  set_matrix(decoder.uniform("u_view_projection"), frame.projection * frame.view);
  // Pixels per mm at unit depth at this resolution: the cross-fade reads
  // the yarn's width in the frame's pixels.
  glUniform1f(decoder.uniform("u_yarn_px_mm"), how.fade.yarn_width_mm * frame.focal_px);
  glUniform2f(decoder.uniform("u_fade_px"), how.fade.from_px, how.fade.full_px);
  glUniform3fv(decoder.uniform("u_eye"), 1, frame.eye.data());
  glUniform4fv(decoder.uniform("u_light"), 1, frame.light.data());
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  glBindVertexArray(gl.array);
  glDrawElements(GL_TRIANGLES, index_count_, GL_UNSIGNED_INT, nullptr);

  // Laid over the frame: over the yarns while they cross-fade, else over
  // what lies beneath.
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, static_cast<GLuint>(how.target));
  glViewport(0, 0, how.viewport.width, how.viewport.height);
  const GlProgram& composite = *gl.composite;
  composite.use();
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, gl.decoded);
  glUniform1i(composite.uniform("u_decoded"), 0);
  glUniform2f(composite.uniform("u_viewport"), static_cast<float>(how.viewport.width),
              static_cast<float>(how.viewport.height));
  glUniform1i(composite.uniform("u_encode_srgb"), how.fade.encode_srgb ? 1 : 0);
  glEnable(GL_BLEND);
  glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  glBindVertexArray(gl.empty_array);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindVertexArray(0);
  glDisable(GL_BLEND);
  glEnable(GL_DEPTH_TEST);
  glBindTexture(GL_TEXTURE_2D, 0);
}

}  // namespace psrig::preview
