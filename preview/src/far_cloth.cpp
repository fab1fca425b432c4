#include "psrig/preview/far_cloth.h"

#include <GLES3/gl3.h>
#include <algorithm>
#include <cstdint>
#include <optional>

#include "gl_program.h"
#include "grid_indices.h"

namespace psrig::preview {
namespace {

constexpr int kFarFloatsPerVertex = 7;  // position, (u, v), place on the shade grid

}  // namespace

struct FarCloth::Gl {
  std::optional<GlProgram> program;
  GLuint array = 0, vertices = 0, indices = 0, area_table = 0;
  cv::Size area_texels;  // the repeat's, in the area table's level
  cv::Vec4f area_mean;
  ~Gl() {
    glDeleteBuffers(1, &vertices);
    glDeleteBuffers(1, &indices);
    glDeleteVertexArrays(1, &array);
    glDeleteTextures(1, &area_table);
  }
};

Result<std::unique_ptr<FarCloth>> FarCloth::create() {
  std::unique_ptr<FarCloth> cloth(new FarCloth);
  cloth->gl_ = std::make_unique<Gl>();
  Gl& gl = *cloth->gl_;
  auto program = GlProgram::build(shaders::far_cloth_vert, shaders::far_cloth_frag);
  if (!program) return std::unexpected(program.error());
  gl.program = std::move(*program);
  glGenVertexArrays(1, &gl.array);
  glGenBuffers(1, &gl.vertices);
  glGenBuffers(1, &gl.indices);
  glGenTextures(1, &gl.area_table);
  return cloth;
}

FarCloth::~FarCloth() = default;

void FarCloth::update(const cloth::YarnSurface& surface, const RepeatWindow& window) {
  const cloth::StitchMesh& mesh = surface.mesh;
  Gl& gl = *gl_;
  vertices_.resize(static_cast<std::size_t>((mesh.columns + 1) * (mesh.rows + 1)) *
                   kFarFloatsPerVertex);
  std::size_t at = 0;
  for (int row = 0; row <= mesh.rows; ++row)
    for (int column = 0; column <= mesh.columns; ++column) {
      const Eigen::Vector3f& p = mesh.vertex(column, row);
      vertices_[at++] = p.x();
      vertices_[at++] = p.y();
      vertices_[at++] = p.z();
      vertices_[at++] =
          static_cast<float>(column - window.first_column) / static_cast<float>(window.columns);
      vertices_[at++] =
          static_cast<float>(row - window.first_row) / static_cast<float>(window.rows);
      vertices_[at++] = static_cast<float>(column) / static_cast<float>(std::max(mesh.columns, 1));
      vertices_[at++] = static_cast<float>(row) / static_cast<float>(std::max(mesh.rows, 1));
    }
  glBindVertexArray(gl.array);
  glBindBuffer(GL_ARRAY_BUFFER, gl.vertices);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices_.size() * sizeof(float)),
               vertices_.data(), GL_DYNAMIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, kFarFloatsPerVertex * sizeof(float), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 2, GL_FLOAT, GL_FALSE, kFarFloatsPerVertex * sizeof(float),
                        reinterpret_cast<const void*>(3 * sizeof(float)));
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(2, 2, GL_FLOAT, GL_FALSE, kFarFloatsPerVertex * sizeof(float),
                        reinterpret_cast<const void*>(5 * sizeof(float)));
  if (mesh.columns != columns_ || mesh.rows != rows_) {
    columns_ = mesh.columns;
    rows_ = mesh.rows;
    index_count_ = upload_grid_indices(gl.indices, columns_, rows_);
  }
  glBindVertexArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
}

void FarCloth::upload(const std::vector<cv::Mat>& levels) {
  if (levels.empty()) return;
  Gl& gl = *gl_;
  // The area table of the finest level at most kAreaTableSide a side (16
  // MB of float texels at most).
  // far_cloth.frag takes every pixel's mean from it; the mipmaps (a tap a
  // pixel, or a few) did worse and no anisotropic filtering helped: on
  // llvmpipe it blurred the stitches (every RMSE of far_level_test 2-5
  // higher) and doubled the far frame's time.
  constexpr int kAreaTableSide = 512;
  std::size_t chosen = 0;
  while (chosen + 1 < levels.size() &&
         std::max(levels[chosen].cols, levels[chosen].rows) > kAreaTableSide)
    ++chosen;
  const AreaTable table = repeat_area_table(levels[chosen]);
  gl.area_texels = levels[chosen].size();
  gl.area_mean = table.mean;
  glBindTexture(GL_TEXTURE_2D, gl.area_table);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, table.sums.cols, table.sums.rows, 0, GL_RGBA, GL_FLOAT,
               table.sums.ptr<float>());
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
  // Fetched, never filtered: a GPU's bilinear weights have 8 fractional
  // bits, too coarse for the differences of large sums a footprint's mean
  // is (and on llvmpipe its own sixteen fetches cost what four filtered
  // lookups do: 92 against 89 ms a 1080p far frame).
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glBindTexture(GL_TEXTURE_2D, 0);
  has_texture_ = true;
}

void FarCloth::draw(const KnitFrame& frame, const FarClothDraw& how) const {
  if (!ready()) return;
  const Gl& gl = *gl_;
  const GlProgram& program = *gl.program;
  program.use();
  set_matrix(program.uniform("u_view_projection"), frame.projection * frame.view);
  glUniform1f(program.uniform("u_yarn_px_mm"), how.yarn_width_mm * frame.focal_px);
  glUniform2f(program.uniform("u_fade_px"), how.from_px, how.full_px);
  glUniform1i(program.uniform("u_over_yarns"), how.over_yarns ? 1 : 0);
  glUniform3f(program.uniform("u_background"), how.background[0], how.background[1],
              how.background[2]);
  glUniform1i(program.uniform("u_encode_srgb"), how.encode_srgb ? 1 : 0);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, gl.area_table);
  glUniform1i(program.uniform("u_area_table"), 0);
  glUniform2f(program.uniform("u_area_texels"), static_cast<float>(gl.area_texels.width),
              static_cast<float>(gl.area_texels.height));
  glUniform4f(program.uniform("u_area_mean"), gl.area_mean[0], gl.area_mean[1], gl.area_mean[2],
              gl.area_mean[3]);
  glUniform3fv(program.uniform("u_shade[0]"), kShadeGrid * kShadeGrid, shade_.front().data());
  glDisable(GL_CULL_FACE);
  // Over yarns: cross-faded, no depth (the mesh lies amid its yarns).
  // Alone: depth tested against what lies beneath, folds hiding folds.
  if (how.over_yarns) {
    glDisable(GL_DEPTH_TEST);
  } else {
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LEQUAL);
    glDepthMask(GL_TRUE);
  }
  glEnable(GL_BLEND);
  glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  glBindVertexArray(gl.array);
  glDrawElements(GL_TRIANGLES, index_count_, GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
  glDisable(GL_BLEND);
  glEnable(GL_DEPTH_TEST);
  glBindTexture(GL_TEXTURE_2D, 0);
}

}  // namespace psrig::preview
