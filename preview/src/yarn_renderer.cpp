#include "psrig/preview/yarn_renderer.h"

#include <GLES3/gl3.h>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "far_level.h"
#include "gl_program.h"
#include "psrig/base/parallel.h"
#include "psrig/cloth/srgb.h"
#include "psrig/preview/clear_frame.h"
#include "psrig/preview/patch_tile.h"
#include "psrig/preview/strip_points.h"

namespace psrig::preview {
namespace {

// One centreline point as yarn.vert reads it: 24 bytes.
struct PackedPoint {
  float position_arc[4];        // mm; arc length from the yarn's start
  std::int8_t normal_lift[4];   // signed normalised: the cloth's normal, lift (clamped to +-1)
  std::uint8_t colour_seed[4];  // sRGB colour (exact for #RRGGBB), the yarn's phase
};
static_assert(sizeof(PackedPoint) == 24);

struct CurveRange {
  std::size_t first = 0;  // index in the packed buffer
  std::size_t count = 0;
};

// One point of padding either end: every point has a previous and a next
// to read (yarn.vert tells another yarn's by its arc length).
constexpr std::size_t kPadding = 1;
constexpr GLuint kShadowUnit = 0, kSliceUnit = 1;

std::int8_t snorm8(float value) {
  const float scaled = std::clamp(value, -1.0f, 1.0f) * 127.0f;
  return static_cast<std::int8_t>(scaled + (scaled < 0 ? -0.5f : 0.5f));
}

float smoothstep(float edge0, float edge1, float x) {
  const float t = std::clamp((x - edge0) / std::max(edge1 - edge0, 1e-6f), 0.0f, 1.0f);
  return t * t * (3 - 2 * t);
}

}  // namespace

// Linear colour to sRGB bytes, remembering the last one (a yarn's points
// mostly share their colour, and pow is the costly part).
class YarnRenderer::ColourBytes {
 public:
  const std::uint8_t* operator()(const Eigen::Vector3f& colour) {
    if (colour != last_) {
      last_ = colour;
      for (int c = 0; c < 3; ++c)
        bytes_[c] = static_cast<std::uint8_t>(
            std::lround(cloth::srgb_encode(std::clamp(colour[c], 0.0f, 1.0f)) * 255.0f));
    }
    return bytes_;
  }

 private:
  Eigen::Vector3f last_ = Eigen::Vector3f::Constant(-1);
  std::uint8_t bytes_[3] = {};
};

// The points of every yarn back to back, with padding at either end, and
// what choosing a frame's points needs of them.
struct YarnRenderer::Packed {
  std::vector<PackedPoint> points;
  std::vector<CentrelinePoint> centreline;  // one per packed point
  std::vector<CurveRange> curves;
  // This frame's strips by layer, and all of them back to back for upload.
  std::array<std::vector<std::uint32_t>, kLayers> layers;
  std::vector<std::uint32_t> indices;
};

// Where each layer's strips lie in an element buffer.
struct YarnRenderer::Strips {
  GLenum mode = GL_TRIANGLE_STRIP;  // or GL_TRIANGLES, layered
  std::array<GLsizei, kLayers> count{};
  std::array<std::size_t, kLayers> offset{};  // bytes
};

struct YarnRenderer::Gl {
  // Shading programs by [fibre detail][shadow map], the halo's and the
  // far view's by [shadow map], and the depth pass.
  std::optional<GlProgram> shading[2][2];
  std::optional<GlProgram> halo[2];
  std::optional<GlProgram> far[2];
  std::optional<GlProgram> depth;
  GLuint array = 0, buffer = 0;
  std::size_t buffer_bytes = 0;
  // The frame's strips for the eye and for the shadow map, apart so that
  // writing one never waits for a draw from the other.
  GLuint elements[2] = {};
  std::size_t element_bytes[2] = {};
  GLuint shadow_map = 0, shadow_framebuffer = 0;
  int shadow_size = 0;
  GLuint slice = 0;
  ~Gl() {
    glDeleteBuffers(1, &buffer);
    glDeleteBuffers(2, elements);
    glDeleteVertexArrays(1, &array);
    glDeleteFramebuffers(1, &shadow_framebuffer);
    glDeleteTextures(1, &shadow_map);
    glDeleteTextures(1, &slice);
  }
};

Result<std::unique_ptr<YarnRenderer>> YarnRenderer::create(const YarnRendererOptions& options) {
  std::unique_ptr<YarnRenderer> renderer(new YarnRenderer);
  renderer->options_ = options;
  renderer->packed_ = std::make_unique<Packed>();
  renderer->gl_ = std::make_unique<Gl>();
  Gl& gl = *renderer->gl_;
  const std::string srgb = options.encode_srgb ? "#define ENCODE_SRGB 1\n" : "";
  const std::string fibres(shaders::yarn_fibres_glsl.text);
  const auto build = [&](const std::string& defines) {
    return GlProgram::build(shaders::yarn_vert, shaders::yarn_frag, defines + srgb + fibres);
  };
  for (const int detail : {0, 1})
    for (const int shadows : {0, 1}) {
      std::string defines;
      if (detail) defines += "#define FIBRE_DETAIL 1\n";
      if (shadows) defines += "#define SHADOWS 1\n";
      auto program = build(defines);
      if (!program) return std::unexpected(program.error());
      gl.shading[detail][shadows].emplace(std::move(*program));
      if (!detail) {
        auto far = build(defines + "#define FAR 1\n");
        if (!far) return std::unexpected(far.error());
        gl.far[shadows].emplace(std::move(*far));
        continue;
      }
      auto halo = build(defines + "#define HALO 1\n");
      if (!halo) return std::unexpected(halo.error());
      gl.halo[shadows].emplace(std::move(*halo));
    }
  auto depth = GlProgram::build(shaders::yarn_vert, shaders::yarn_depth_frag,
                                "#define DEPTH_PASS 1\n" + fibres);
  if (!depth) return std::unexpected(depth.error());
  gl.depth.emplace(std::move(*depth));

  // One vertex array: the points read at three offsets (previous, this,
  // next) and the frame's element buffer of strips.
  glGenVertexArrays(1, &gl.array);
  glBindVertexArray(gl.array);
  glGenBuffers(1, &gl.buffer);
  glGenBuffers(2, gl.elements);
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

  if (options.level != YarnLevel::near) {
    auto far = FarLevel::create(options);
    if (!far) return std::unexpected(far.error());
    renderer->far_ = std::move(*far);
  }
  renderer->slice_ = bake_yarn_slice(renderer->style_, options.slice);
  renderer->upload_slice();
  if (const GLenum error = glGetError(); error != GL_NO_ERROR)
    return std::unexpected(internal_error("GL error " + std::to_string(error) +
                                          " while setting up the yarn renderer"));
  return renderer;
}

YarnRenderer::~YarnRenderer() = default;

int YarnRenderer::repeat_bakes() const {
  return far_ ? far_->bakes() : 0;
}

Status YarnRenderer::set_woven(const WovenFarMaterial& material) {
  if (!far_ || options_.woven_far != WovenFar::neural) return {};
  const std::filesystem::path weights =
      options_.woven_weights.empty() ? find_woven_weights() : options_.woven_weights;
  return far_->set_woven(material, weights);
}

void YarnRenderer::clear_woven() {
  if (far_) far_->clear_woven();
}

bool YarnRenderer::neural_far() const {
  return far_ && far_->neural();
}

float YarnRenderer::far_from_px() const {
  return neural_far() ? options_.woven_far_from_px : options_.far_cloth_from_px;
}

// The slice and its mipmaps, made on the CPU (chen2003 eq. 11), as a
// texture that repeats along the yarn and stops at the halo's edge.
void YarnRenderer::upload_slice() {
  ++bakes_;
  GLuint& texture = gl_->slice;
  glDeleteTextures(1, &texture);  // immutable storage: a new size needs a new texture
  glGenTextures(1, &texture);
  glActiveTexture(GL_TEXTURE0 + kSliceUnit);
  glBindTexture(GL_TEXTURE_2D, texture);
  const auto levels = static_cast<GLsizei>(slice_.levels.size());
  glTexStorage2D(GL_TEXTURE_2D, levels, GL_RGBA8, slice_.levels[0].width, slice_.levels[0].height);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  for (GLsizei level = 0; level < levels; ++level) {
    const YarnSliceLevel& data = slice_.levels[static_cast<std::size_t>(level)];
    glTexSubImage2D(GL_TEXTURE_2D, level, 0, 0, data.width, data.height, GL_RGBA,
                    GL_UNSIGNED_BYTE, data.texels.data());
  }
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
  glActiveTexture(GL_TEXTURE0);
}

// One yarn's points into the packed buffer from `first`, and what choosing
// its strip's points needs of them.
void YarnRenderer::pack_yarn(const cloth::YarnCurve& curve, std::size_t index, std::size_t first,
                             ColourBytes& colour_bytes, Eigen::Array3f& low,
                             Eigen::Array3f& high) {
  Packed& packed = *packed_;
  const std::size_t count = curve.points.size();
  // A phase of its own per yarn, so that the slice's pattern does not
  // line up from yarn to yarn.
  const auto seed = static_cast<std::uint8_t>((index * 2654435761U) >> 24);
  const bool normals = curve.normals.size() >= count;
  const bool lifts = curve.lift.size() >= count;
  const bool colours = curve.colours.size() >= count;
  const Eigen::Vector3f default_normal = Eigen::Vector3f::UnitZ();
  float arc = 0;
  Eigen::Vector3f before = Eigen::Vector3f::Zero();  // the piece into this point, unit
  float slope_before = 0;                             // of the lift, per mm
  std::size_t next = first;
  for (std::size_t i = 0; i < count; ++i) {
    const Eigen::Vector3f& point = curve.points[i];
    CentrelinePoint& facts = packed.centreline[next];
    const float lift = lifts ? curve.lift[i] : 1.0f;
    if (i + 1 < count) {
      const Eigen::Vector3f piece = curve.points[i + 1] - point;
      facts.length_mm = piece.norm();
      const Eigen::Vector3f after =
          facts.length_mm > 0 ? Eigen::Vector3f(piece / facts.length_mm) : before;
      const float slope_after =
          lifts && facts.length_mm > 0 ? (curve.lift[i + 1] - lift) / facts.length_mm : 0.0f;
      // 2 sin(angle / 2): the angle itself where it matters (small), no acos.
      if (i > 0) {
        facts.turn = (after - before).norm();
        facts.lift_turn = std::abs(slope_after - slope_before);
      }
      before = after;
      slope_before = slope_after;
    }
    if (i > 0) arc += packed.centreline[next - 1].length_mm;
    low = low.min(point.array());
    high = high.max(point.array());
    const Eigen::Vector3f& normal = normals ? curve.normals[i] : default_normal;
    const Eigen::Vector3f& colour = colours ? curve.colours[i] : style_.colour;
    facts.keep = colours && i > 0 && colour != curve.colours[i - 1];
    const std::uint8_t* bytes = colour_bytes(colour);
    packed.points[next++] = {{point.x(), point.y(), point.z(), arc},
                             {snorm8(normal.x()), snorm8(normal.y()), snorm8(normal.z()),
                              snorm8(lift)},
                             {bytes[0], bytes[1], bytes[2], seed}};
  }
}

void YarnRenderer::update(const cloth::YarnSet& yarns) {
  surface_only_ = false;
  ++yarn_updates_;
  if (far_) far_->update(yarns);
  if (!same_slice(yarns.style, slice_.style)) {
    slice_ = bake_yarn_slice(yarns.style, options_.slice);
    upload_slice();
  }
  style_ = yarns.style;
  Packed& packed = *packed_;
  packed.curves.clear();
  // Where each yarn goes in the buffer, then the yarns packed side by side
  // on the thread pool, a few at a time.
  const int yarn_count = static_cast<int>(yarns.curves.size());
  std::vector<std::size_t> firsts(yarns.curves.size());
  std::size_t total = kPadding;
  for (std::size_t index = 0; index < yarns.curves.size(); ++index) {
    firsts[index] = total;
    total += yarns.curves[index].points.size();
    if (yarns.curves[index].points.size() >= 3)
      packed.curves.push_back({firsts[index], yarns.curves[index].points.size()});
  }
  const std::size_t next = total;
  total += kPadding;
  packed.points.resize(total);
  packed.centreline.assign(total, CentrelinePoint{});
  // Arc length rises along each yarn: the front padding's never lies
  // behind a first point, the back padding's never ahead of a last one.
  PackedPoint padding{};
  padding.position_arc[3] = std::numeric_limits<float>::max();
  std::fill_n(packed.points.begin(), kPadding, padding);
  constexpr int kChunk = 8;
  const int chunks = psrig::chunk_count(yarn_count, kChunk);
  std::vector<Eigen::Array3f> lows(static_cast<std::size_t>(chunks),
                                   Eigen::Array3f::Constant(std::numeric_limits<float>::max()));
  std::vector<Eigen::Array3f> highs(static_cast<std::size_t>(chunks),
                                    Eigen::Array3f::Constant(-std::numeric_limits<float>::max()));
  psrig::parallel_chunks(yarn_count, kChunk, [&](int begin, int end) {
    ColourBytes colour_bytes;
    Eigen::Array3f& low = lows[static_cast<std::size_t>(begin / kChunk)];
    Eigen::Array3f& high = highs[static_cast<std::size_t>(begin / kChunk)];
    for (int index = begin; index < end; ++index)
      pack_yarn(yarns.curves[static_cast<std::size_t>(index)], static_cast<std::size_t>(index),
                firsts[static_cast<std::size_t>(index)], colour_bytes, low, high);
  });
  Eigen::Array3f low = Eigen::Array3f::Constant(std::numeric_limits<float>::max());
  Eigen::Array3f high = -low;
  for (int chunk = 0; chunk < chunks; ++chunk) {
    low = low.min(lows[static_cast<std::size_t>(chunk)]);
    high = high.max(highs[static_cast<std::size_t>(chunk)]);
  }
  padding.position_arc[3] = -1;
  std::fill_n(packed.points.begin() + static_cast<std::ptrdiff_t>(next), kPadding, padding);
  bounds_.setEmpty();
  if (next > kPadding) {
    bounds_.extend(Eigen::Vector3f(low.matrix()));
    bounds_.extend(Eigen::Vector3f(high.matrix()));
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

void point_attributes() {
  constexpr std::size_t size = sizeof(PackedPoint);
  const auto at = [](std::size_t offset) { return reinterpret_cast<const void*>(offset); };
  constexpr auto stride = static_cast<GLsizei>(size);
  // Index i reads point i at location 1, its neighbours at 0 and 2.
  glVertexAttribPointer(0, 4, GL_FLOAT, GL_FALSE, stride, at(0));
  glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, stride, at(size));
  glVertexAttribPointer(2, 4, GL_FLOAT, GL_FALSE, stride, at(2 * size));
  glVertexAttribPointer(3, 4, GL_BYTE, GL_TRUE, stride, at(size + offsetof(PackedPoint, normal_lift)));
  glVertexAttribPointer(4, 4, GL_UNSIGNED_BYTE, GL_TRUE, stride,
                        at(size + offsetof(PackedPoint, colour_seed)));
}

}  // namespace

// The strips of every yarn through the points this scale draws into
// element buffer `which` (indices one less than the packed points': the
// attribute at location 1 starts a point in); `layered`, as separate
// triangles by layer as seen from `eye` (position, w = 1; or direction,
// w = 0), back to front.
YarnRenderer::Strips YarnRenderer::choose_points(float px_per_mm, const PieceLimits& limits,
                                                 const Eigen::Vector4f& eye, bool layered,
                                                 unsigned which) {
  Packed& packed = *packed_;
  packed.indices.clear();
  for (const CurveRange& curve : packed.curves)
    append_strip(packed.centreline, curve.first, curve.count, px_per_mm, limits, packed.indices);
  Strips strips;
  strips.mode = GL_TRIANGLE_STRIP;
  if (layered) {
    const auto layer_of = [&](std::uint32_t index) {
      const PackedPoint& point = packed.points[index];
      const Eigen::Vector3f to_eye =
          eye.head<3>() - eye.w() * Eigen::Vector3f(point.position_arc[0], point.position_arc[1],
                                                    point.position_arc[2]);
      const float facing = to_eye.x() * point.normal_lift[0] + to_eye.y() * point.normal_lift[1] +
                           to_eye.z() * point.normal_lift[2];
      const float lift = static_cast<float>(point.normal_lift[3]) / 127.0f;
      return cloth_layer(facing >= 0 ? lift : -lift);
    };
    for (auto& layer : packed.layers) layer.clear();
    layer_triangles(packed.indices, layer_of, packed.layers);
    packed.indices.clear();
    for (int layer = 0; layer < kLayers; ++layer) {
      strips.offset[layer] = packed.indices.size() * sizeof(std::uint32_t);
      strips.count[layer] = static_cast<GLsizei>(packed.layers[layer].size());
      packed.indices.insert(packed.indices.end(), packed.layers[layer].begin(),
                            packed.layers[layer].end());
    }
    strips.mode = GL_TRIANGLES;
  } else {
    strips.count[0] = static_cast<GLsizei>(packed.indices.size());
  }
  for (std::uint32_t& index : packed.indices)
    if (index != kRestartIndex) --index;
  const std::size_t bytes = packed.indices.size() * sizeof(std::uint32_t);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, gl_->elements[which]);
  if (bytes > gl_->element_bytes[which]) {
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(bytes), packed.indices.data(),
                 GL_STREAM_DRAW);
    gl_->element_bytes[which] = bytes;
  } else {
    glBufferSubData(GL_ELEMENT_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(bytes),
                    packed.indices.data());
  }
  return strips;
}

namespace {

// Each layer's strips (or triangles) in turn, in the order given.
void draw_strips(GLenum mode, const std::array<GLsizei, kLayers>& count,
                 const std::array<std::size_t, kLayers>& offset, int instances = 1) {
  for (int layer = 0; layer < kLayers; ++layer) {
    if (count[layer] == 0) continue;
    const auto* at = reinterpret_cast<const void*>(offset[layer]);
    if (instances > 1)
      glDrawElementsInstanced(mode, count[layer], GL_UNSIGNED_INT, at, instances);
    else
      glDrawElements(mode, count[layer], GL_UNSIGNED_INT, at);
  }
}

// The nearest and farthest the bounds lie from the eye along its axis,
// the nearest no closer than a hundredth of the camera's distance.
std::pair<float, float> depth_range(const Eigen::AlignedBox3f& bounds, const KnitFrame& frame) {
  if (frame.orthographic) return {frame.distance, frame.distance};
  float nearest = std::numeric_limits<float>::max(), farthest = 0;
  if (!bounds.isEmpty())
    for (int corner = 0; corner < 8; ++corner) {
      const float depth =
          (frame.view *
           bounds.corner(static_cast<Eigen::AlignedBox3f::CornerType>(corner)).homogeneous())
              .z();
      nearest = std::min(nearest, -depth);
      farthest = std::max(farthest, -depth);
    }
  nearest = std::max(nearest, 0.01f * frame.distance);
  farthest = std::max(farthest, nearest);
  return {nearest, farthest};
}

// The state the yarns draw in: depth tested and written, opaque, no culling.
void yarn_state() {
  glDisable(GL_CULL_FACE);  // strips face the eye either way round
  glDisable(GL_BLEND);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glDepthMask(GL_TRUE);
}

// What every yarn program of a frame is told (yarn.vert, yarn.frag).
struct YarnUniforms {
  const KnitFrame& frame;
  const KnitView& view;
  const YarnRendererOptions& options;
  const cloth::YarnStyle& style;
  const YarnSlice& slice;
  Eigen::Matrix4f view_projection;
  Eigen::Vector4f eye;  // position, w = 1
  float radius = 0, flatness = 1;
  bool blending = false;
  GLuint shadow_map = 0, slice_texture = 0;
  int shadow_extent = 0, shadow_size = 1;  // texels a side: in use, and of the map
  float map_strength = 0;
  ColourMatch colour;
};

void use_yarn_program(const GlProgram& program, const YarnUniforms& u) {
  const KnitFrame& frame = u.frame;
  const YarnRendererOptions& options = u.options;
  const FibreShading& shading = options.shading;
  const auto& environment = options.environment.coefficients();
  const float turn_scale =
      u.style.twist_pitch_mm > 0 ? u.style.twist_pitch_mm / u.slice.period_mm : 0.0f;
  program.use();
  set_matrix(program.uniform("u_view_projection"), u.view_projection);
  glUniform4fv(program.uniform("u_eye"), 1, u.eye.data());
  glUniform1f(program.uniform("u_radius"), u.radius);
  glUniform1f(program.uniform("u_flatness"), u.flatness);
  glUniform1f(program.uniform("u_focal_px"), frame.focal_px);
  // Widened only where it will be blended as transparent as it is thin.
  glUniform1f(program.uniform("u_min_half_px"), u.blending ? options.min_strip_px / 2 : 0.0f);
  glUniform1f(program.uniform("u_halo"), u.slice.halo);
  glUniform2f(program.uniform("u_halo_fade_px"), options.halo_from_px, options.halo_full_px);
  glUniform1f(program.uniform("u_period"), u.slice.period_mm);
  glUniform1f(program.uniform("u_turn_scale"), turn_scale);
  glUniform1f(program.uniform("u_slice_phase"), frame.slice_phase);
  glUniform1f(program.uniform("u_ply_slant_sin"), u.slice.ply_slant_sin);
  glUniform4fv(program.uniform("u_light"), 1, frame.light.data());
  glUniform1f(program.uniform("u_reference_distance"), frame.light_reference_distance);
  glUniform3fv(program.uniform("u_environment[0]"), 9, environment[0].data());
  glUniform1f(program.uniform("u_environment_scale"), shading.environment);
  glUniform1f(program.uniform("u_environment_fibre"), shading.environment_fibre);
  glUniform1f(program.uniform("u_environment_sheen"),
              shading.environment_sheen * u.colour.sheen_gain);
  glUniform1f(program.uniform("u_local_scattering"), shading.local_scattering);
  glUniform1f(program.uniform("u_global_scattering"), shading.global_scattering);
  glUniform1f(program.uniform("u_crossing_occlusion"), shading.crossing_occlusion);
  // No yarn shadows asked for: none, statistical or mapped.
  glUniform1f(program.uniform("u_shadow_density"), u.view.shadows ? shading.shadow_density : 0.0f);
  glUniform3fv(program.uniform("u_light_colour"), 1, shading.light_colour.data());
  glUniform3fv(program.uniform("u_albedo_gain"), 1, u.colour.albedo_gain.data());
  glUniform1f(program.uniform("u_diffuse"), shading.diffuse);
  glUniform1f(program.uniform("u_wrap"), shading.wrap);
  glUniform3f(program.uniform("u_reflection"), shading.r_weight * u.colour.sheen_gain,
              shading.r_shift, shading.r_width);
  glUniform3f(program.uniform("u_transmission"), shading.tt_weight, shading.tt_shift,
              shading.tt_width);
  glUniform1f(program.uniform("u_ply_relief"), shading.ply_relief);
  glUniform1f(program.uniform("u_helix_sin"), std::sin(ply_helix_angle(u.style)));
  const FibreSurface mean =
      u.view.fibre_detail ? slice_surface(u.slice.core_mean) : plain_surface(u.style);
  glUniform3f(program.uniform("u_mean_surface"), mean.ply_offset, mean.tilt_sin, mean.light);
  // Forced near: the fibre detail at full strength whatever the width.
  if (options.level == YarnLevel::near)
    glUniform2f(program.uniform("u_far_px"), -2.0f, -1.0f);
  else
    glUniform2f(program.uniform("u_far_px"), options.detail_from_px, options.detail_full_px);
  glUniform1f(program.uniform("u_prefilter_px"), options.prefilter_px);
  glUniform2f(program.uniform("u_prefilter_fade_px"), options.prefilter_from_px,
              options.prefilter_until_px);
  glActiveTexture(GL_TEXTURE0 + kShadowUnit);
  glBindTexture(GL_TEXTURE_2D, u.shadow_map);
  glUniform1i(program.uniform("u_shadow_map"), kShadowUnit);
  glActiveTexture(GL_TEXTURE0 + kSliceUnit);
  glBindTexture(GL_TEXTURE_2D, u.slice_texture);
  glUniform1i(program.uniform("u_slice"), kSliceUnit);
  glActiveTexture(GL_TEXTURE0);
  set_matrix(program.uniform("u_shadow_view_projection"), frame.shadow_view_projection);
  // Half a radius: a yarn's lit half never shadows itself.
  glUniform1f(program.uniform("u_shadow_bias"), 0.5f * u.radius / frame.shadow_depth_range);
  glUniform1f(program.uniform("u_shadow_extent"),
              static_cast<float>(u.shadow_extent) / static_cast<float>(u.shadow_size));
  glUniform1f(program.uniform("u_shadow_strength"), u.map_strength);
}

}  // namespace

Status YarnRenderer::use_scan(const PatchTile& tile) {
  return far_ ? far_->use_scan(tile) : Status{};
}

bool YarnRenderer::update_far_only(const cloth::YarnSurface& surface, const cloth::YarnStyle& style,
                                   const KnitFrame& frame, const Eigen::AlignedBox3f& bounds) {
  if (!far_ || !far_->scanned()) return false;
  // As plan_frame() would decide with these bounds: no yarn where every
  // one is under far_cloth_full_px.
  const float widest_px = 2 * style.radius_mm * frame.focal_px / depth_range(bounds, frame).first;
  if (options_.level == YarnLevel::automatic && widest_px > options_.far_cloth_full_px)
    return false;
  if (!far_->update_surface(surface)) return false;
  style_ = style;
  bounds_ = bounds;
  surface_only_ = true;
  return true;
}

// What a frame draws, decided by how wide its yarns look.
struct YarnRenderer::FramePlan {
  float radius = 0;
  float flatness = 1;
  float pixels_per_mm = 0;  // at the bounds centre
  float widest_px = 0, narrowest_px = 0;  // the yarn at the bounds' nearest and farthest
  bool far_cloth = false;                 // the far level's textured mesh
  bool yarns = false;                     // the yarns, at whichever level
  bool drawing = false;     // there are yarns to draw
  bool blending = false;    // strips blended, as transparent as they are thin
  // The shadow map: drawn at all, its extent in use (texels a side), its
  // scale, and how far it has taken over from the statistical shadows.
  bool shadows = false;
  int shadow_extent = 0;
  float texels_per_mm = 0;
  float map_strength = 0;
};

YarnRenderer::FramePlan YarnRenderer::plan_frame(const KnitFrame& frame, const KnitView& view) {
  const YarnRendererOptions& options = options_;
  FramePlan plan;
  plan.radius = style_.radius_mm;
  plan.flatness = std::clamp(style_.flatness, 0.05f, 1.0f);
  plan.pixels_per_mm = frame.focal_px / frame.distance;
  last_width_px_ = 2 * plan.radius * plan.pixels_per_mm;
  plan.drawing = !packed_->curves.empty() || surface_only_;

  // The widest a yarn can look (at the bounds' nearest depth) decides the
  // halo pass, the narrowest (head on, at the farthest) the blending.
  const auto [nearest, farthest] = depth_range(bounds_, frame);
  const float widest_px = 2 * plan.radius * frame.focal_px / nearest;
  const float narrowest_px = 2 * plan.radius * frame.focal_px / farthest;
  plan.widest_px = widest_px;
  plan.narrowest_px = narrowest_px;
  // The far level's mesh wherever a yarn is under far_cloth_from_px, and
  // nothing else once every one is under far_cloth_full_px.
  const bool surface = far_ && far_->has_surface();
  plan.far_cloth = plan.drawing && surface &&
                   (options.level == YarnLevel::far ||
                    (options.level == YarnLevel::automatic && narrowest_px < far_from_px()));
  plan.yarns = plan.drawing && !surface_only_ &&
               (!plan.far_cloth ||
                (options.level == YarnLevel::automatic && widest_px > options.far_cloth_full_px));
  last_far_cloth_ = plan.far_cloth;
  last_yarns_ = plan.yarns;
  last_halo_ = plan.yarns && view.fibre_detail && widest_px > options.halo_from_px;
  last_far_ = options.level == YarnLevel::far ||
              (options.level == YarnLevel::automatic && widest_px <= options.detail_from_px);
  // The far view's widening at its narrowest yarn (yarn.vert's `prefilter`).
  const float widest_prefilter_px =
      options.prefilter_px *
      (1 - smoothstep(options.prefilter_from_px, options.prefilter_until_px, narrowest_px));
  plan.blending = last_far_ ? widest_prefilter_px > 0 : narrowest_px < options.min_strip_px;

  // The map need be no finer than the screen: as many texels across the
  // bounds as pixels would cover them at the centre's distance.
  plan.shadow_extent =
      std::clamp(static_cast<int>(std::ceil(frame.shadow_depth_range * plan.pixels_per_mm)), 256,
                 gl_->shadow_size);
  plan.texels_per_mm = static_cast<float>(plan.shadow_extent) / frame.shadow_depth_range;
  plan.map_strength = smoothstep(options.map_from_texels, options.map_full_texels,
                                 2 * plan.radius * plan.texels_per_mm);
  plan.shadows = view.shadows && plan.yarns && plan.map_strength > 0;
  last_shadow_map_ = plan.shadows;
  return plan;
}

// Which centreline points this frame draws (strip_points.h), for its yarns'
// width and whether the shadow map is in use.
PieceLimits YarnRenderer::piece_limits(const FramePlan& plan) const {
  const YarnRendererOptions& options = options_;
  // Shadows need vertices close enough to show where a crossing's falls.
  PieceLimits limits = options.pieces;
  // A piece shorter than the yarn is wide shows nothing a longer one would
  // not; a few pixels are enough for any (a strip's sides take turns, so a
  // long piece leaves each side a vertex every other piece).
  // Coarser while the yarn is a couple of pixels wide (its loops' shape is
  // then more than the eye resolves), finer as it grows: both gradually,
  // as a jump in the points drawn would show.
  const float fine = smoothstep(2.0f, 6.0f, last_width_px_);
  limits.lift_tolerance += (options.near_lift_tolerance - limits.lift_tolerance) * fine;
  // Short pieces once the yarn is over half a pixel wide (the options' note).
  const float shorter =
      smoothstep(options.short_pieces_from_px, options.short_pieces_full_px, last_width_px_) *
      (1.0f - smoothstep(options.short_pieces_until_px, options.short_pieces_off_px, last_width_px_));
  const auto toward = [shorter](float from, float to) { return from + (to - from) * shorter; };
  const float widths = toward(options.min_piece_widths, options.short_piece_widths);
  const float cap_px = toward(options.min_piece_cap_px, options.short_piece_cap_px);
  limits.max_px = toward(limits.max_px, options.short_piece_max_px);
  limits.tolerance_px = toward(limits.tolerance_px, options.short_piece_tolerance_px);
  const float cap = cap_px + (1.0f - cap_px) * fine;
  limits.min_px = std::clamp(widths * last_width_px_, limits.min_px, std::max(limits.min_px, cap));
  limits.tolerance_px = std::min(limits.tolerance_px, options.tolerance_widths * last_width_px_);
  limits.half_width_px = last_width_px_ / 2;
  // Where the points kept change the loops' look (with the long pieces,
  // under a pixel the prefilter hides it, and there dithering only adds noise).
  limits.dither = options.piece_dither * smoothstep(1.5f, 3.0f, last_width_px_);
  // Short pieces change their points as the scale changes, every loop at
  // once with one limit: dithered from the start.
  limits.dither = std::max(limits.dither, options.short_piece_dither * shorter);
  // As the map takes over, shorter pieces (continuously: a jump in the
  // points drawn would show).
  if (plan.shadows)
    limits.max_px +=
        (std::min(limits.max_px, options.shadowed_piece_px) - limits.max_px) * plan.map_strength;
  return limits;
}

// The shadow pass: the yarns' depth seen from the light into the shadow
// map's framebuffer, then the caller's `target` bound again.
void YarnRenderer::draw_shadow_map(const KnitFrame& frame, const FramePlan& plan,
                                   const PieceLimits& limits, unsigned target) {
  const Gl& gl = *gl_;
  const Strips map_strips =
      choose_points(plan.texels_per_mm, limits, Eigen::Vector4f::Zero(), false, 1);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, gl.shadow_framebuffer);
  glViewport(0, 0, plan.shadow_extent, plan.shadow_extent);
  glEnable(GL_SCISSOR_TEST);
  glScissor(0, 0, plan.shadow_extent, plan.shadow_extent);
  glClear(GL_DEPTH_BUFFER_BIT);
  glDisable(GL_SCISSOR_TEST);
  const GlProgram& depth = *gl.depth;
  depth.use();
  set_matrix(depth.uniform("u_view_projection"), frame.shadow_view_projection);
  const Eigen::Vector4f toward_light(frame.toward_shadow_light.x(), frame.toward_shadow_light.y(),
                                     frame.toward_shadow_light.z(), 0);
  glUniform4fv(depth.uniform("u_eye"), 1, toward_light.data());
  glUniform1f(depth.uniform("u_radius"), plan.radius);
  glUniform1f(depth.uniform("u_flatness"), plan.flatness);
  draw_strips(map_strips.mode, map_strips.count, map_strips.offset);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, static_cast<GLuint>(target));
}

// The yarn pass (the far view's, or the near view's with its fibre
// detail), then the halo pass over it.
void YarnRenderer::draw_yarns(const KnitFrame& frame, const KnitView& view, const FramePlan& plan,
                              const PieceLimits& limits) {
  const Gl& gl = *gl_;
  const bool shadows = plan.shadows, blending = plan.blending;
  const Eigen::Vector4f eye(frame.eye.x(), frame.eye.y(), frame.eye.z(), 1);
  const YarnUniforms uniforms{.frame = frame,
                              .view = view,
                              .options = options_,
                              .style = style_,
                              .slice = slice_,
                              .view_projection = frame.projection * frame.view,
                              .eye = eye,
                              .radius = plan.radius,
                              .flatness = plan.flatness,
                              .blending = blending,
                              .shadow_map = gl.shadow_map,
                              .slice_texture = gl.slice,
                              .shadow_extent = plan.shadow_extent,
                              .shadow_size = gl.shadow_size,
                              .map_strength = plan.map_strength,
                              .colour = colour_match_};

  // Layers order only blended far frames; the depth test orders the rest.
  const Strips strips = choose_points(plan.pixels_per_mm, limits, eye, last_far_ && blending, 0);
  last_strip_vertices_ = 0;
  for (const GLsizei count : strips.count)
    last_strip_vertices_ += count;
  if (last_far_) {
    // Yarns thinner than their prefiltered strips: blended back to front
    // through the cloth's layers, no depth test (the samples cannot tell
    // such depths apart, and a strip's soft edge must not hide what lies
    // behind it). "Over" makes a pixel's coverage 1 - prod(1 - alpha), the
    // union of yarns that overlap at random; the nearer's colour on top.
    use_yarn_program(*gl.far[shadows], uniforms);
    glUniform1f(gl.far[shadows]->uniform("u_soft_edges"), blending ? 1.0f : 0.0f);
    if (blending) {
      glDisable(GL_DEPTH_TEST);
      glEnable(GL_BLEND);
      glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    }
    draw_strips(strips.mode, strips.count, strips.offset);
    glEnable(GL_DEPTH_TEST);
  } else {
    use_yarn_program(*gl.shading[view.fibre_detail][shadows], uniforms);
    if (blending) {
      glEnable(GL_BLEND);
      glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    }
    draw_strips(strips.mode, strips.count, strips.offset);
  }
  if (last_halo_) {
    // Over the cores, hidden by nearer ones, writing no depth: the halo of
    // one yarn must not hide another behind it.
    use_yarn_program(*gl.halo[shadows], uniforms);
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    glDepthMask(GL_FALSE);
    draw_strips(strips.mode, strips.count, strips.offset, 2);
    glDepthMask(GL_TRUE);
  }
  glDisable(GL_BLEND);
}

void YarnRenderer::render(const KnitView& view, cv::Size viewport,
                          const std::function<void(const KnitFrame&)>& beneath) {
  render(knit_frame(bounds_, view, viewport), view, viewport, beneath);
}

void YarnRenderer::render(const KnitFrame& frame, const KnitView& view, cv::Size viewport,
                          const std::function<void(const KnitFrame&)>& beneath) {
  GLint target = 0;
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &target);
  const Gl& gl = *gl_;
  const FramePlan plan = plan_frame(frame, view);
  // A bake draws into its own framebuffer first.
  if (plan.far_cloth) far_->prepare(frame, view, static_cast<unsigned>(target), viewport);
  if (far_)
    if (const auto match = far_->match_scan(frame, view, static_cast<unsigned>(target), viewport))
      colour_match_ = *match;

  yarn_state();
  glEnable(GL_PRIMITIVE_RESTART_FIXED_INDEX);
  glBindVertexArray(gl.array);
  glBindBuffer(GL_ARRAY_BUFFER, gl.buffer);
  point_attributes();
  const PieceLimits limits = piece_limits(plan);
  if (plan.shadows) draw_shadow_map(frame, plan, limits, static_cast<GLuint>(target));

  clear_frame(view.background, options_.encode_srgb, viewport);
  if (beneath) {
    beneath(frame);
    yarn_state();
    glBindVertexArray(gl.array);
    glBindBuffer(GL_ARRAY_BUFFER, gl.buffer);
  }
  if (plan.yarns) {
    draw_yarns(frame, view, plan, limits);
  } else {
    last_strip_vertices_ = 0;
  }
  if (plan.far_cloth) {
    const bool forced = options_.level == YarnLevel::far;
    far_->draw(frame, {.yarn_width_mm = 2 * plan.radius,
                       .from_px = forced ? 2e9f : far_from_px(),
                       .full_px = forced ? 1e9f : options_.far_cloth_full_px,
                       .over_yarns = plan.yarns,
                       .background = view.background,
                       .encode_srgb = options_.encode_srgb});
  }
  glDisable(GL_PRIMITIVE_RESTART_FIXED_INDEX);
  glBindVertexArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
}

}  // namespace psrig::preview
