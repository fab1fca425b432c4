#include "psrig/preview/scan_surface.h"

#include <GLES3/gl3.h>
#include <algorithm>
#include <cstdint>
#include <optional>
#include <string>

#include "gl_program.h"
#include "grid_indices.h"
#include "psrig/preview/texture_levels.h"

namespace psrig::preview {
namespace {

// position, normal, tangent, (u, v), the environment's light front and back
constexpr int kFloatsPerVertex = 17;

void upload_levels(GLuint texture, const std::vector<cv::Mat>& levels, GLint internal_format,
                   GLenum type) {
  glBindTexture(GL_TEXTURE_2D, texture);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  for (std::size_t level = 0; level < levels.size(); ++level)
    glTexImage2D(GL_TEXTURE_2D, static_cast<GLint>(level), internal_format, levels[level].cols,
                 levels[level].rows, 0, GL_RGBA, type, levels[level].data);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, static_cast<GLint>(levels.size()) - 1);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
  glBindTexture(GL_TEXTURE_2D, 0);
}

// A vertex's unit normal and tangent (along the courses) from its
// neighbours across and up, one-sided at the mesh's edges.
void tangent_frame(const cloth::StitchMesh& mesh, int column, int row, Eigen::Vector3f& normal,
                   Eigen::Vector3f& tangent) {
  const Eigen::Vector3f across = mesh.vertex(std::min(column + 1, mesh.columns), row) -
                                 mesh.vertex(std::max(column - 1, 0), row);
  const Eigen::Vector3f up =
      mesh.vertex(column, std::min(row + 1, mesh.rows)) - mesh.vertex(column, std::max(row - 1, 0));
  normal = across.cross(up);
  normal = normal.squaredNorm() > 0 ? normal.normalized().eval() : Eigen::Vector3f::UnitZ().eval();
  tangent = across - normal.dot(across) * normal;
  tangent =
      tangent.squaredNorm() > 0 ? tangent.normalized().eval() : normal.unitOrthogonal().eval();
}

}  // namespace

struct ScanSurface::Gl {
  std::optional<GlProgram> program;
  GLuint array = 0, vertices = 0, indices = 0, albedo = 0, normal = 0;
  ~Gl() {
    glDeleteBuffers(1, &vertices);
    glDeleteBuffers(1, &indices);
    glDeleteVertexArrays(1, &array);
    glDeleteTextures(1, &albedo);
    glDeleteTextures(1, &normal);
  }
};

Result<std::unique_ptr<ScanSurface>> ScanSurface::create(const PatchTile& tile,
                                                         const ShadingParams& shading) {
  std::unique_ptr<ScanSurface> surface(new ScanSurface);
  surface->gl_ = std::make_unique<Gl>();
  Gl& gl = *surface->gl_;
  auto program = GlProgram::build(shaders::scan_surface_vert, shaders::scan_surface_frag,
                                  std::string(shaders::surface_lighting_glsl.text));
  if (!program) return std::unexpected(program.error());
  gl.program.emplace(std::move(*program));
  glGenTextures(1, &gl.albedo);
  glGenTextures(1, &gl.normal);
  glGenVertexArrays(1, &gl.array);
  glGenBuffers(1, &gl.vertices);
  glGenBuffers(1, &gl.indices);
  if (auto set = surface->set_tile(tile, shading); !set) return std::unexpected(set.error());
  return surface;
}

Status ScanSurface::set_tile(const PatchTile& tile, const ShadingParams& shading) {
  if (!(tile.maps.pixel_size_mm > 0))
    return std::unexpected(bad_input(tile.maps.directory, {},
                                     "the scan's pixel size is not known: no physical size to "
                                     "tile its maps at"));
  Gl& gl = *gl_;
  GLint max_size = 0;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
  const TextureLevels levels =
      build_texture_levels(tile.maps, shading.default_gloss, std::max(max_size, 64));
  upload_levels(gl.albedo, levels.albedo_alpha, GL_SRGB8_ALPHA8, GL_UNSIGNED_BYTE);
  upload_levels(gl.normal, levels.normal_gloss, GL_RGBA16F, GL_HALF_FLOAT);
  if (const GLenum error = glGetError(); error != GL_NO_ERROR)
    return std::unexpected(internal_error("GL error " + std::to_string(error) +
                                          " while uploading the scan's tile " + tile.source));
  shading_ = shading;
  tile_mm_ = tile.maps.extent();
  return {};
}

ScanSurface::~ScanSurface() = default;

void ScanSurface::update(const cloth::StitchMesh& mesh, const EnvironmentLight& environment,
                         float environment_scale) {
  Gl& gl = *gl_;
  vertices_.resize(static_cast<std::size_t>((mesh.columns + 1) * (mesh.rows + 1)) *
                   kFloatsPerVertex);
  // The tile at its physical size over the mesh at rest.
  const auto u_per_column = static_cast<float>(mesh.face_width_mm / tile_mm_.width);
  const auto v_per_row = static_cast<float>(mesh.face_height_mm / tile_mm_.height);
  std::size_t at = 0;
  const auto put = [&](const Eigen::Vector3f& value) {
    for (int i = 0; i < 3; ++i)
      vertices_[at++] = value[i];
  };
  for (int row = 0; row <= mesh.rows; ++row)
    for (int column = 0; column <= mesh.columns; ++column) {
      Eigen::Vector3f normal, tangent;
      tangent_frame(mesh, column, row, normal, tangent);
      put(mesh.vertex(column, row));
      put(normal);
      put(tangent);
      vertices_[at++] = static_cast<float>(column) * u_per_column;
      vertices_[at++] = static_cast<float>(row) * v_per_row;
      put(environment_scale * environment.lambert(normal));
      put(environment_scale * environment.lambert(-normal));
    }
  glBindVertexArray(gl.array);
  glBindBuffer(GL_ARRAY_BUFFER, gl.vertices);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices_.size() * sizeof(float)),
               vertices_.data(), GL_DYNAMIC_DRAW);
  const auto attribute = [](GLuint location, GLint size, int offset) {
    glEnableVertexAttribArray(location);
    glVertexAttribPointer(location, size, GL_FLOAT, GL_FALSE, kFloatsPerVertex * sizeof(float),
                          reinterpret_cast<const void*>(offset * sizeof(float)));
  };
  attribute(0, 3, 0);
  attribute(1, 3, 3);
  attribute(2, 3, 6);
  attribute(3, 2, 9);
  attribute(4, 3, 11);
  attribute(5, 3, 14);
  if (mesh.columns != columns_ || mesh.rows != rows_) {
    columns_ = mesh.columns;
    rows_ = mesh.rows;
    index_count_ = upload_grid_indices(gl.indices, columns_, rows_);
  }
  glBindVertexArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
}

void ScanSurface::set_light_response(std::vector<Eigen::Vector3f> response) {
  if (!response.empty() && response.size() != kResponseSamples) response.clear();
  response_ = std::move(response);
}

void ScanSurface::draw(const KnitFrame& frame, const FarClothDraw& how) const {
  if (!ready()) return;
  const Gl& gl = *gl_;
  const GlProgram& program = *gl.program;
  program.use();
  set_matrix(program.uniform("u_view_projection"), frame.projection * frame.view);
  glUniform3fv(program.uniform("u_eye"), 1, frame.eye.data());
  glUniform4fv(program.uniform("u_light"), 1, frame.light.data());
  glUniform1f(program.uniform("u_lift_mm"), how.over_yarns ? how.yarn_width_mm : 0.0f);
  glUniform1f(program.uniform("u_yarn_px_mm"), how.yarn_width_mm * frame.focal_px);
  glUniform1f(program.uniform("u_diffuse"), shading_.diffuse);
  glUniform1f(program.uniform("u_specular"), shading_.specular);
  glUniform1f(program.uniform("u_shininess"), shading_.shininess);
  glUniform3fv(program.uniform("u_light_colour"), 1, shading_.light_colour.val);
  glUniform1f(program.uniform("u_point_light"), frame.light.w());
  glUniform1f(program.uniform("u_reference_distance"), frame.light_reference_distance);
  glUniform2f(program.uniform("u_fade_px"), how.from_px, how.full_px);
  glUniform1i(program.uniform("u_over_yarns"), how.over_yarns ? 1 : 0);
  glUniform1i(program.uniform("u_encode_srgb"), how.encode_srgb ? 1 : 0);
  glUniform1i(program.uniform("u_responds"), response_.empty() ? 0 : 1);
  if (!response_.empty())
    glUniform3fv(program.uniform("u_response[0]"), kResponseSamples, response_.front().data());
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, gl.albedo);
  glUniform1i(program.uniform("u_albedo_alpha"), 0);
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_2D, gl.normal);
  glUniform1i(program.uniform("u_normal_gloss"), 1);
  glDisable(GL_CULL_FACE);  // a fold shows the cloth's back
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glDepthMask(GL_TRUE);
  glEnable(GL_BLEND);
  glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  glBindVertexArray(gl.array);
  glDrawElements(GL_TRIANGLES, index_count_, GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
  glDisable(GL_BLEND);
  glBindTexture(GL_TEXTURE_2D, 0);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, 0);
}

}  // namespace psrig::preview
