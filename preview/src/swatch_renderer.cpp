#include "psrig/preview/swatch_renderer.h"

#include <GLES3/gl3.h>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>

#include "gl_program.h"
#include "psrig/preview/clear_frame.h"
#include "psrig/preview/texture_levels.h"

namespace psrig::preview {
// A mesh's GL objects (SwatchRenderer::Gl holds them, so not in the
// anonymous namespace).
struct SwatchMesh {
  GLuint array = 0, vertices = 0, indices = 0;
  GLsizei count = 0;
};

namespace {

constexpr GLenum kTextureMaxAnisotropy = 0x84FE;  // GL_EXT_texture_filter_anisotropic

void upload_levels(GLuint texture, const std::vector<cv::Mat>& levels, GLint internal_format,
                   GLenum type, const RendererOptions& options) {
  glBindTexture(GL_TEXTURE_2D, texture);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  const std::size_t count = options.mipmaps ? levels.size() : 1;
  for (std::size_t level = 0; level < count; ++level) {
    const cv::Mat& image = levels[level];
    glTexImage2D(GL_TEXTURE_2D, static_cast<GLint>(level), internal_format, image.cols, image.rows,
                 0, GL_RGBA, type, image.data);
  }
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, static_cast<GLint>(count) - 1);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER,
                  options.mipmaps ? GL_LINEAR_MIPMAP_LINEAR : GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
  if (options.max_anisotropy > 1)
    glTexParameterf(GL_TEXTURE_2D, kTextureMaxAnisotropy, options.max_anisotropy);
}

SwatchMesh upload_patch(const cloth::PatchMesh& patch) {
  SwatchMesh mesh;
  glGenVertexArrays(1, &mesh.array);
  glBindVertexArray(mesh.array);
  glGenBuffers(1, &mesh.vertices);
  glBindBuffer(GL_ARRAY_BUFFER, mesh.vertices);
  glBufferData(GL_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(patch.vertices.size() * sizeof(cloth::PatchVertex)),
               patch.vertices.data(), GL_STATIC_DRAW);
  const auto attribute = [](GLuint location, GLint size, std::size_t offset) {
    glEnableVertexAttribArray(location);
    glVertexAttribPointer(location, size, GL_FLOAT, GL_FALSE, sizeof(cloth::PatchVertex),
                          reinterpret_cast<const void*>(offset));
  };
  attribute(0, 3, offsetof(cloth::PatchVertex, position));
  attribute(1, 3, offsetof(cloth::PatchVertex, normal));
  attribute(2, 3, offsetof(cloth::PatchVertex, tangent));
  attribute(3, 3, offsetof(cloth::PatchVertex, bitangent));
  attribute(4, 2, offsetof(cloth::PatchVertex, uv));
  glGenBuffers(1, &mesh.indices);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, mesh.indices);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(patch.indices.size() * sizeof(std::uint32_t)),
               patch.indices.data(), GL_STATIC_DRAW);
  mesh.count = static_cast<GLsizei>(patch.indices.size());
  glBindVertexArray(0);
  return mesh;
}

// A unit UV sphere, as a triangle list of positions.
SwatchMesh upload_sphere() {
  constexpr int kStacks = 12, kSlices = 20;
  std::vector<float> positions;
  std::vector<std::uint32_t> indices;
  for (int stack = 0; stack <= kStacks; ++stack)
    for (int slice = 0; slice <= kSlices; ++slice) {
      const double polar = std::numbers::pi * stack / kStacks;
      const double around = 2 * std::numbers::pi * slice / kSlices;
      positions.insert(positions.end(), {static_cast<float>(std::sin(polar) * std::cos(around)),
                                         static_cast<float>(std::sin(polar) * std::sin(around)),
                                         static_cast<float>(std::cos(polar))});
    }
  for (int stack = 0; stack < kStacks; ++stack)
    for (int slice = 0; slice < kSlices; ++slice) {
      const auto a = static_cast<std::uint32_t>(stack * (kSlices + 1) + slice);
      const auto b = a + kSlices + 1;
      indices.insert(indices.end(), {a, b, a + 1, a + 1, b, b + 1});
    }
  SwatchMesh mesh;
  glGenVertexArrays(1, &mesh.array);
  glBindVertexArray(mesh.array);
  glGenBuffers(1, &mesh.vertices);
  glBindBuffer(GL_ARRAY_BUFFER, mesh.vertices);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(positions.size() * sizeof(float)),
               positions.data(), GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 3 * sizeof(float), nullptr);
  glGenBuffers(1, &mesh.indices);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, mesh.indices);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(indices.size() * sizeof(std::uint32_t)), indices.data(),
               GL_STATIC_DRAW);
  mesh.count = static_cast<GLsizei>(indices.size());
  glBindVertexArray(0);
  return mesh;
}

void release(SwatchMesh& mesh) {
  glDeleteBuffers(1, &mesh.vertices);
  glDeleteBuffers(1, &mesh.indices);
  glDeleteVertexArrays(1, &mesh.array);
  mesh = {};
}

}  // namespace

struct SwatchRenderer::Gl {
  std::optional<GlProgram> swatch, marker;
  GLuint albedo = 0, normal = 0;
  SwatchMesh patches[2];  // indexed by cloth::PatchShape
  SwatchMesh sphere;
  bool blend = false;  // only with an alpha map: opaque swatches skip it
  ~Gl() {
    glDeleteTextures(1, &albedo);
    glDeleteTextures(1, &normal);
    for (auto& patch : patches)
      release(patch);
    release(sphere);
  }
};

Result<std::unique_ptr<SwatchRenderer>> SwatchRenderer::create(const SwatchMaps& maps,
                                                               const RendererOptions& options) {
  std::unique_ptr<SwatchRenderer> renderer(new SwatchRenderer);
  renderer->options_ = options;
  renderer->extent_ = maps.extent();
  renderer->gl_ = std::make_unique<Gl>();
  Gl& gl = *renderer->gl_;
  auto swatch = GlProgram::build(shaders::swatch_vert, shaders::swatch_frag,
                                 (maps.alpha.empty() ? std::string() : "#define ALPHA_MAP 1\n") +
                                     std::string(shaders::surface_lighting_glsl.text));
  if (!swatch) return std::unexpected(swatch.error());
  gl.swatch.emplace(std::move(*swatch));
  auto marker = GlProgram::build(shaders::light_marker_vert, shaders::light_marker_frag);
  if (!marker) return std::unexpected(marker.error());
  gl.marker.emplace(std::move(*marker));

  GLint max_size = 0;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
  const TextureLevels levels =
      build_texture_levels(maps, options.shading.default_gloss, std::max(max_size, 64));
  renderer->levels_ = static_cast<int>(levels.albedo_alpha.size());
  gl.blend = !maps.alpha.empty();
  glGenTextures(1, &gl.albedo);
  upload_levels(gl.albedo, levels.albedo_alpha, GL_SRGB8_ALPHA8, GL_UNSIGNED_BYTE, options);
  glGenTextures(1, &gl.normal);
  upload_levels(gl.normal, levels.normal_gloss, GL_RGBA16F, GL_HALF_FLOAT, options);

  for (const cloth::PatchShape shape : {cloth::PatchShape::flat, cloth::PatchShape::draped}) {
    SceneView view;
    view.kind = shape == cloth::PatchShape::flat ? ViewKind::flat : ViewKind::patch;
    const cv::Size2d extent = frame_setup(renderer->extent_, view, {1, 1}).patch_extent;
    const int segments = shape == cloth::PatchShape::flat ? 1 : options.segments;
    gl.patches[static_cast<int>(shape)] = upload_patch(
        cloth::tessellate(cloth::BezierPatch::make(shape, extent), segments, extent, renderer->extent_));
  }
  gl.sphere = upload_sphere();
  if (const GLenum error = glGetError(); error != GL_NO_ERROR)
    return std::unexpected(internal_error("GL error " + std::to_string(error) +
                                          " while uploading " + maps.directory.string()));
  return renderer;
}

SwatchRenderer::~SwatchRenderer() = default;

void SwatchRenderer::draw(const SceneView& view, cv::Size viewport) {
  const FrameSetup setup = frame_setup(extent_, view, viewport);
  const Eigen::Matrix4f view_projection = setup.projection * setup.view;
  clear_frame(options_.background, options_.encode_srgb, viewport);
  glEnable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);  // the draped sheet shows its back
  if (gl_->blend) {
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  } else {
    glDisable(GL_BLEND);
  }

  const GlProgram& swatch = *gl_->swatch;
  const ShadingParams& shading = options_.shading;
  swatch.use();
  set_matrix(swatch.uniform("u_model"), setup.model);
  set_matrix(swatch.uniform("u_view_projection"), view_projection);
  glUniform4fv(swatch.uniform("u_eye"), 1, setup.eye.data());
  glUniform4fv(swatch.uniform("u_light"), 1, setup.light.data());
  glUniform1f(swatch.uniform("u_ambient"), shading.ambient);
  glUniform1f(swatch.uniform("u_diffuse"), shading.diffuse);
  glUniform1f(swatch.uniform("u_specular"), shading.specular);
  glUniform1f(swatch.uniform("u_shininess"), shading.shininess);
  glUniform3fv(swatch.uniform("u_light_colour"), 1, shading.light_colour.val);
  glUniform1f(swatch.uniform("u_point_light"), setup.light[3]);
  glUniform1f(swatch.uniform("u_reference_distance"), setup.light_reference_distance);
  glUniform1i(swatch.uniform("u_encode_srgb"), options_.encode_srgb ? 1 : 0);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, gl_->albedo);
  glUniform1i(swatch.uniform("u_albedo_alpha"), 0);
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_2D, gl_->normal);
  glUniform1i(swatch.uniform("u_normal_gloss"), 1);
  const SwatchMesh& patch = gl_->patches[static_cast<int>(setup.shape)];
  glBindVertexArray(patch.array);
  glDrawElements(GL_TRIANGLES, patch.count, GL_UNSIGNED_INT, nullptr);

  if (view.show_light) {
    const GlProgram& marker = *gl_->marker;
    marker.use();
    set_matrix(marker.uniform("u_view_projection"), view_projection);
    glUniform3fv(marker.uniform("u_centre"), 1, setup.marker_centre.data());
    glUniform1f(marker.uniform("u_radius"), setup.marker_radius);
    const Eigen::Vector3f to_viewer =
        (setup.eye.head<3>() - setup.eye[3] * setup.marker_centre).normalized();
    glUniform3fv(marker.uniform("u_to_viewer"), 1, to_viewer.data());
    glUniform3fv(marker.uniform("u_colour"), 1, shading.light_colour.val);
    glUniform1i(marker.uniform("u_encode_srgb"), options_.encode_srgb ? 1 : 0);
    glBindVertexArray(gl_->sphere.array);
    glDrawElements(GL_TRIANGLES, gl_->sphere.count, GL_UNSIGNED_INT, nullptr);
  }
  glBindVertexArray(0);
}

}  // namespace psrig::preview
