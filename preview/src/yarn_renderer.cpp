#include "psrig/preview/yarn_renderer.h"

#include <GLES3/gl3.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "gl_program.h"
#include "psrig/preview/clear_frame.h"

namespace psrig::preview {
namespace {

// One centreline point as yarn.vert reads it: 32 bytes.
struct PackedPoint {
  float position_arc[4];        // mm; arc length from the yarn's start
  std::int16_t normal_lift[4];  // signed normalised: the cloth's normal, lift (clamped to +-1)
  std::uint16_t colour[4];      // unsigned normalised linear RGB, unused
};
static_assert(sizeof(PackedPoint) == 32);

struct CurveRange {
  std::size_t first = 0;  // index in the packed buffer
  GLsizei count = 0;
};

// Far away a yarn is drawn through every step-th point only (its pieces
// under a few pixels long add vertices, not shape): the buffer's padding
// lets a step that large read past either end.
constexpr int kMaxStep = 32;
constexpr std::size_t kPadding = kMaxStep;

std::int16_t snorm16(float value) {
  return static_cast<std::int16_t>(std::lround(std::clamp(value, -1.0f, 1.0f) * 32767.0f));
}

std::uint16_t unorm16(float value) {
  return static_cast<std::uint16_t>(std::lround(std::clamp(value, 0.0f, 1.0f) * 65535.0f));
}

}  // namespace

// The points of every yarn back to back, with padding at either end so
// that the previous and next points can always be read.
struct YarnRenderer::Packed {
  std::vector<PackedPoint> points;
  std::vector<CurveRange> curves;
  float mean_spacing_mm = 0;  // between neighbouring points
};

struct YarnRenderer::Gl {
  // Shading programs by [lines][shadows][fibre detail], and the depth pass.
  std::optional<GlProgram> shading[2][2][2];
  std::optional<GlProgram> depth;
  GLuint array = 0, buffer = 0;
  std::size_t buffer_bytes = 0;
  GLuint shadow_map = 0, shadow_framebuffer = 0;
  int shadow_size = 0;
  ~Gl() {
    glDeleteBuffers(1, &buffer);
    glDeleteVertexArrays(1, &array);
    glDeleteFramebuffers(1, &shadow_framebuffer);
    glDeleteTextures(1, &shadow_map);
  }
};

Result<std::unique_ptr<YarnRenderer>> YarnRenderer::create(const YarnRendererOptions& options) {
  std::unique_ptr<YarnRenderer> renderer(new YarnRenderer);
  renderer->options_ = options;
  renderer->packed_ = std::make_unique<Packed>();
  renderer->gl_ = std::make_unique<Gl>();
  Gl& gl = *renderer->gl_;
  for (const int lines : {0, 1})
    for (const int shadows : {0, 1})
      for (const int detail : {0, 1}) {
        std::string defines;
        if (lines) defines += "#define LINES 1\n";
        if (shadows) defines += "#define SHADOWS 1\n";
        if (detail) defines += "#define FIBRE_DETAIL 1\n";
        if (options.encode_srgb) defines += "#define ENCODE_SRGB 1\n";
        auto program = GlProgram::build(shaders::yarn_vert, shaders::yarn_frag, defines);
        if (!program) return std::unexpected(program.error());
        gl.shading[lines][shadows][detail].emplace(std::move(*program));
      }
  auto depth = GlProgram::build(shaders::yarn_vert, shaders::yarn_depth_frag);
  if (!depth) return std::unexpected(depth.error());
  gl.depth.emplace(std::move(*depth));

  glGenVertexArrays(1, &gl.array);
  glBindVertexArray(gl.array);
  glGenBuffers(1, &gl.buffer);
  glBindBuffer(GL_ARRAY_BUFFER, gl.buffer);
  for (GLuint location = 0; location < 5; ++location)
    glEnableVertexAttribArray(location);
  glBindVertexArray(0);

  GLint max_size = 0;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
  gl.shadow_size = std::clamp(options.shadow_map_size, 16, std::max(max_size, 16));
  glGenTextures(1, &gl.shadow_map);
  glBindTexture(GL_TEXTURE_2D, gl.shadow_map);
  glTexStorage2D(GL_TEXTURE_2D, 1, GL_DEPTH_COMPONENT24, gl.shadow_size, gl.shadow_size);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);  // bilinear PCF
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
  GLint previous_framebuffer = 0;
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &previous_framebuffer);
  glGenFramebuffers(1, &gl.shadow_framebuffer);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, gl.shadow_framebuffer);
  glFramebufferTexture2D(GL_DRAW_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, gl.shadow_map, 0);
  const GLenum none = GL_NONE;
  glDrawBuffers(1, &none);
  const bool complete = glCheckFramebufferStatus(GL_DRAW_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, static_cast<GLuint>(previous_framebuffer));
  if (!complete)
    return std::unexpected(internal_error("the yarn shadow map's framebuffer is incomplete"));
  if (const GLenum error = glGetError(); error != GL_NO_ERROR)
    return std::unexpected(internal_error("GL error " + std::to_string(error) +
                                          " while setting up the yarn renderer"));
  return renderer;
}

YarnRenderer::~YarnRenderer() = default;

void YarnRenderer::update(const cloth::YarnSet& yarns) {
  style_ = yarns.style;
  Packed& packed = *packed_;
  packed.points.clear();
  packed.curves.clear();
  // Arc length rises along each yarn: the front padding's never lies
  // behind a first point, the back padding's never ahead of a last one.
  PackedPoint padding{};
  padding.position_arc[3] = std::numeric_limits<float>::max();
  packed.points.assign(kPadding, padding);
  double total_arc = 0;
  std::size_t pieces = 0;
  bounds_.setEmpty();
  const Eigen::Vector3f default_normal = Eigen::Vector3f::UnitZ();
  for (const cloth::YarnCurve& curve : yarns.curves) {
    const std::size_t first = packed.points.size();
    float arc = 0;
    for (std::size_t i = 0; i < curve.points.size(); ++i) {
      const Eigen::Vector3f& point = curve.points[i];
      if (i > 0) arc += (point - curve.points[i - 1]).norm();
      bounds_.extend(point);
      const Eigen::Vector3f& normal = i < curve.normals.size() ? curve.normals[i] : default_normal;
      const float lift = i < curve.lift.size() ? curve.lift[i] : 1.0f;
      const Eigen::Vector3f& colour = i < curve.colours.size() ? curve.colours[i] : style_.colour;
      packed.points.push_back(
          {{point.x(), point.y(), point.z(), arc},
           {snorm16(normal.x()), snorm16(normal.y()), snorm16(normal.z()), snorm16(lift)},
           {unorm16(colour.x()), unorm16(colour.y()), unorm16(colour.z()), 0}});
    }
    if (curve.points.size() >= 2) {
      packed.curves.push_back({first, static_cast<GLsizei>(curve.points.size())});
      total_arc += arc;
      pieces += curve.points.size() - 1;
    }
  }
  padding.position_arc[3] = -1;
  packed.points.insert(packed.points.end(), kPadding, padding);
  packed.mean_spacing_mm = pieces > 0 ? static_cast<float>(total_arc / pieces) : 0;
  if (!bounds_.isEmpty()) {
    bounds_.min().array() -= style_.radius_mm;
    bounds_.max().array() += style_.radius_mm;
  }

  const std::size_t bytes = packed.points.size() * sizeof(PackedPoint);
  glBindBuffer(GL_ARRAY_BUFFER, gl_->buffer);
  if (bytes == gl_->buffer_bytes) {
    glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(bytes), packed.points.data());
  } else {
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(bytes), packed.points.data(),
                 GL_DYNAMIC_DRAW);
    gl_->buffer_bytes = bytes;
    ++allocations_;
  }
  glBindBuffer(GL_ARRAY_BUFFER, 0);
}

namespace {

// Each curve as one strip through every step-th point: the attributes
// point at the curve's first point, one step apart. A strip needs three
// vertices, so a short curve takes a smaller step (and one of two points
// is not drawn at all).
void draw_curves(const std::vector<CurveRange>& curves, int step) {
  constexpr std::size_t size = sizeof(PackedPoint);
  const auto at = [](std::size_t offset) { return reinterpret_cast<const void*>(offset); };
  for (const CurveRange& curve : curves) {
    const int own_step = std::max(1, std::min(step, (curve.count - 1) / 2));
    const auto stride = static_cast<GLsizei>(own_step * size);
    const std::size_t base = curve.first * size;
    glVertexAttribPointer(0, 4, GL_FLOAT, GL_FALSE, stride, at(base - own_step * size));
    glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, stride, at(base));
    glVertexAttribPointer(2, 4, GL_FLOAT, GL_FALSE, stride, at(base + own_step * size));
    glVertexAttribPointer(3, 4, GL_SHORT, GL_TRUE, stride,
                          at(base + offsetof(PackedPoint, normal_lift)));
    glVertexAttribPointer(4, 3, GL_UNSIGNED_SHORT, GL_TRUE, stride,
                          at(base + offsetof(PackedPoint, colour)));
    glDrawArrays(GL_TRIANGLE_STRIP, 0, (curve.count - 1) / own_step + 1);
  }
}

// The step that keeps a yarn's pieces at least `min_length` units long,
// given how many units a millimetre is.
int point_step(float spacing_mm, float units_per_mm, float min_length) {
  const float piece = spacing_mm * units_per_mm;
  if (piece <= 0) return 1;
  return std::clamp(static_cast<int>(min_length / piece), 1, kMaxStep);
}

}  // namespace

void YarnRenderer::render(const KnitView& view, cv::Size viewport) {
  GLint target = 0;
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &target);
  const Gl& gl = *gl_;
  const KnitFrame frame = knit_frame(bounds_, view, viewport);
  const float radius = style_.radius_mm;
  last_width_px_ = 2 * radius * frame.focal_px / frame.distance;
  const float band = std::max(options_.tubes_from_px - options_.lines_up_to_px, 1e-3f);
  last_tube_weight_ = std::clamp((last_width_px_ - options_.lines_up_to_px) / band, 0.0f, 1.0f);
  const bool drawing = !packed_->curves.empty();

  glDisable(GL_CULL_FACE);  // strips face the eye either way round
  glDisable(GL_BLEND);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glDepthMask(GL_TRUE);
  glBindVertexArray(gl.array);
  glBindBuffer(GL_ARRAY_BUFFER, gl.buffer);
  // Yarn-level shadows fade out with the tubes: under a pixel wide they
  // would be detail no one sees, at the cost of a whole pass.
  const bool shadows = view.shadows && drawing && last_tube_weight_ > 0;
  // The map need be no finer than the screen: as many texels across the
  // bounds as pixels would cover them at the centre's distance.
  const float pixels_per_mm = frame.focal_px / frame.distance;
  const int shadow_extent = std::clamp(
      static_cast<int>(std::ceil(frame.shadow_depth_range * pixels_per_mm)), 256, gl.shadow_size);
  if (shadows) {
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, gl.shadow_framebuffer);
    glViewport(0, 0, shadow_extent, shadow_extent);
    glEnable(GL_SCISSOR_TEST);
    glScissor(0, 0, shadow_extent, shadow_extent);
    glClear(GL_DEPTH_BUFFER_BIT);
    glDisable(GL_SCISSOR_TEST);
    const GlProgram& depth = *gl.depth;
    depth.use();
    set_matrix(depth.uniform("u_view_projection"), frame.shadow_view_projection);
    const Eigen::Vector4f toward_light(frame.toward_shadow_light.x(), frame.toward_shadow_light.y(),
                                       frame.toward_shadow_light.z(), 0);
    glUniform4fv(depth.uniform("u_eye"), 1, toward_light.data());
    glUniform1f(depth.uniform("u_radius"), radius);
    const float texels_per_mm = static_cast<float>(shadow_extent) / frame.shadow_depth_range;
    draw_curves(packed_->curves, point_step(packed_->mean_spacing_mm, texels_per_mm, 3));
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, static_cast<GLuint>(target));
  }

  clear_frame(view.background, options_.encode_srgb, viewport);
  if (!drawing) {
    glBindVertexArray(0);
    glBindBuffer(GL_ARRAY_BUFFER, 0);
    return;
  }

  const Eigen::Matrix4f view_projection = frame.projection * frame.view;
  const Eigen::Vector4f eye(frame.eye.x(), frame.eye.y(), frame.eye.z(), 1);
  const FibreShading& shading = options_.shading;
  const auto set_uniforms = [&](bool lines, float alpha) -> const GlProgram& {
    const GlProgram& program = *gl.shading[lines][shadows][view.fibre_detail];
    program.use();
    set_matrix(program.uniform("u_view_projection"), view_projection);
    glUniform4fv(program.uniform("u_eye"), 1, eye.data());
    glUniform4fv(program.uniform("u_light"), 1, frame.light.data());
    glUniform1f(program.uniform("u_reference_distance"), frame.light_reference_distance);
    glUniform1f(program.uniform("u_radius"), radius);
    glUniform1f(program.uniform("u_helix_angle"), ply_helix_angle(style_));
    glUniform1i(program.uniform("u_plies"), style_.plies);
    glUniform1f(program.uniform("u_twist_pitch"), style_.twist_pitch_mm);
    glUniform1f(program.uniform("u_ambient"), shading.ambient);
    glUniform1f(program.uniform("u_diffuse"), shading.diffuse);
    glUniform1f(program.uniform("u_wrap"), shading.wrap);
    glUniform3f(program.uniform("u_primary"), shading.primary_specular, shading.primary_shift,
                shading.primary_exponent);
    glUniform3f(program.uniform("u_secondary"), shading.secondary_specular, shading.secondary_shift,
                shading.secondary_exponent);
    glUniform1f(program.uniform("u_crossing_occlusion"), shading.crossing_occlusion);
    glUniform1f(program.uniform("u_ply_groove"), shading.ply_groove);
    glUniform1f(program.uniform("u_striation"), shading.striation);
    glUniform1i(program.uniform("u_fibres_per_ply"), shading.fibres_per_ply);
    glUniform3fv(program.uniform("u_light_colour"), 1, shading.light_colour.data());
    glUniform1f(program.uniform("u_mean_detail"), mean_fibre_detail(shading));
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, gl.shadow_map);
    glUniform1i(program.uniform("u_shadow_map"), 0);
    set_matrix(program.uniform("u_shadow_view_projection"), frame.shadow_view_projection);
    // Half a radius: a yarn's lit half never shadows itself, its far half
    // (dark by the wrap term anyway) may.
    glUniform1f(program.uniform("u_shadow_bias"), 0.5f * radius / frame.shadow_depth_range);
    glUniform1f(program.uniform("u_shadow_extent"),
                static_cast<float>(shadow_extent) / static_cast<float>(gl.shadow_size));
    glUniform1f(program.uniform("u_alpha"), alpha);
    glUniform1f(program.uniform("u_half_pixel"), 0.5f / frame.focal_px);
    glUniform1f(program.uniform("u_shadow_strength"), last_tube_weight_);
    return program;
  };

  const int step = point_step(packed_->mean_spacing_mm, pixels_per_mm, options_.min_piece_px);
  if (last_tube_weight_ > 0) {
    set_uniforms(false, 1);
    // Pushed back a little: where lines follow, they win the depth tie.
    const bool lines_follow = last_tube_weight_ < 1;
    if (lines_follow) {
      glEnable(GL_POLYGON_OFFSET_FILL);
      glPolygonOffset(1, 1);
    }
    draw_curves(packed_->curves, step);
    glDisable(GL_POLYGON_OFFSET_FILL);
  }
  if (last_tube_weight_ < 1) {
    // Over the tubes by 1 - weight: the blend of the two images
    // (durupinar2007); alone, a yarn narrower than a pixel covers that much.
    const float coverage = std::min(last_width_px_, 1.0f);
    set_uniforms(true, (1 - last_tube_weight_) * coverage);
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    draw_curves(packed_->curves, step);
    glDisable(GL_BLEND);
  }
  glBindVertexArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
}

}  // namespace psrig::preview
