#include "psrig/preview/prop_renderer.h"

#include <GLES3/gl3.h>
#include <cmath>
#include <numbers>
#include <optional>
#include <type_traits>
#include <variant>

#include <Eigen/Geometry>

#include "gl_program.h"

namespace psrig::preview {
namespace {

constexpr int kAround = 32;  // segments round a sphere or an arm
constexpr int kAlong = 16;   // from pole to pole
// A neutral studio grey for what the cloth lies on, darker for the floor.
const Eigen::Vector3f kSolidColour(0.42f, 0.42f, 0.45f);
const Eigen::Vector3f kFloorColour(0.12f, 0.12f, 0.13f);

void triangle(PropMesh& mesh, const Eigen::Vector3f& a, const Eigen::Vector3f& b,
              const Eigen::Vector3f& c, const Eigen::Vector3f& na, const Eigen::Vector3f& nb,
              const Eigen::Vector3f& nc) {
  mesh.positions.insert(mesh.positions.end(), {a, b, c});
  mesh.normals.insert(mesh.normals.end(), {na, nb, nc});
}

void quad(PropMesh& mesh, const Eigen::Vector3f& a, const Eigen::Vector3f& b,
          const Eigen::Vector3f& c, const Eigen::Vector3f& d, const Eigen::Vector3f& normal) {
  triangle(mesh, a, b, c, normal, normal, normal);
  triangle(mesh, a, c, d, normal, normal, normal);
}

// Two unit vectors square to `axis` and to each other.
std::pair<Eigen::Vector3f, Eigen::Vector3f> square_to(const Eigen::Vector3f& axis) {
  const Eigen::Vector3f other =
      std::abs(axis.x()) < 0.9f ? Eigen::Vector3f::UnitX() : Eigen::Vector3f::UnitY();
  const Eigen::Vector3f u = axis.cross(other).normalized();
  return {u, axis.cross(u)};
}

// The part of a sphere between polar angles `from` and `to` (0: the
// axis's end), its centre at `centre` (a capsule's hemispheres are parts).
void sphere_band(PropMesh& mesh, const Eigen::Vector3f& centre, float radius,
                 const Eigen::Vector3f& axis, float from, float to, int steps) {
  const auto [u, v] = square_to(axis);
  const auto at = [&](float polar, float azimuth) -> Eigen::Vector3f {
    return std::cos(polar) * axis + std::sin(polar) * (std::cos(azimuth) * u + std::sin(azimuth) * v);
  };
  for (int i = 0; i < steps; ++i)
    for (int j = 0; j < kAround; ++j) {
      const float p0 = from + (to - from) * static_cast<float>(i) / static_cast<float>(steps);
      const float p1 = from + (to - from) * static_cast<float>(i + 1) / static_cast<float>(steps);
      const float a0 = 2 * std::numbers::pi_v<float> * static_cast<float>(j) / kAround;
      const float a1 = 2 * std::numbers::pi_v<float> * static_cast<float>(j + 1) / kAround;
      const Eigen::Vector3f n00 = at(p0, a0), n01 = at(p0, a1), n10 = at(p1, a0), n11 = at(p1, a1);
      triangle(mesh, centre + radius * n00, centre + radius * n10, centre + radius * n11, n00, n10,
               n11);
      triangle(mesh, centre + radius * n00, centre + radius * n11, centre + radius * n01, n00, n11,
               n01);
    }
}

void add(PropMesh& mesh, const cloth::SphereCollider& sphere) {
  sphere_band(mesh, sphere.centre, sphere.radius, Eigen::Vector3f::UnitY(), 0,
              std::numbers::pi_v<float>, kAlong);
}

void add(PropMesh& mesh, const cloth::CapsuleCollider& capsule) {
  const Eigen::Vector3f along = capsule.b - capsule.a;
  const float length = along.norm();
  const Eigen::Vector3f axis = length > 0 ? Eigen::Vector3f(along / length) : Eigen::Vector3f::UnitX();
  const auto [u, v] = square_to(axis);
  for (int j = 0; j < kAround; ++j) {
    const float a0 = 2 * std::numbers::pi_v<float> * static_cast<float>(j) / kAround;
    const float a1 = 2 * std::numbers::pi_v<float> * static_cast<float>(j + 1) / kAround;
    const Eigen::Vector3f n0 = std::cos(a0) * u + std::sin(a0) * v;
    const Eigen::Vector3f n1 = std::cos(a1) * u + std::sin(a1) * v;
    const float r = capsule.radius;
    triangle(mesh, capsule.a + r * n0, capsule.b + r * n0, capsule.b + r * n1, n0, n0, n1);
    triangle(mesh, capsule.a + r * n0, capsule.b + r * n1, capsule.a + r * n1, n0, n1, n1);
  }
  const float half = std::numbers::pi_v<float> / 2;
  sphere_band(mesh, capsule.b, capsule.radius, axis, 0, half, kAlong / 2);
  sphere_band(mesh, capsule.a, capsule.radius, -axis, 0, half, kAlong / 2);
}

void add(PropMesh& mesh, const cloth::BoxCollider& box) {
  const Eigen::Vector3f& l = box.low;
  const Eigen::Vector3f& h = box.high;
  const auto p = [&](int x, int y, int z) {
    return Eigen::Vector3f(x ? h.x() : l.x(), y ? h.y() : l.y(), z ? h.z() : l.z());
  };
  quad(mesh, p(0, 1, 0), p(0, 1, 1), p(1, 1, 1), p(1, 1, 0), Eigen::Vector3f::UnitY());   // top
  quad(mesh, p(0, 0, 0), p(1, 0, 0), p(1, 0, 1), p(0, 0, 1), -Eigen::Vector3f::UnitY());  // bottom
  quad(mesh, p(0, 0, 1), p(1, 0, 1), p(1, 1, 1), p(0, 1, 1), Eigen::Vector3f::UnitZ());   // front
  quad(mesh, p(0, 0, 0), p(0, 1, 0), p(1, 1, 0), p(1, 0, 0), -Eigen::Vector3f::UnitZ());  // back
  quad(mesh, p(1, 0, 0), p(1, 1, 0), p(1, 1, 1), p(1, 0, 1), Eigen::Vector3f::UnitX());   // right
  quad(mesh, p(0, 0, 0), p(0, 0, 1), p(0, 1, 1), p(0, 1, 0), -Eigen::Vector3f::UnitX());  // left
}

void add(PropMesh& mesh, const cloth::PlaneCollider& plane, const Eigen::Vector3f& centre,
         float extent) {
  const Eigen::Vector3f n = plane.normal.normalized();
  const Eigen::Vector3f middle = centre - n * n.dot(centre - plane.point);
  const auto [u, v] = square_to(n);
  const float e = extent / 2;
  quad(mesh, middle - e * u - e * v, middle + e * u - e * v, middle + e * u + e * v,
       middle - e * u + e * v, n);
}

}  // namespace

PropMesh prop_mesh(const std::vector<cloth::Collider>& colliders, const Eigen::Vector3f& centre,
                   float plane_extent_mm) {
  PropMesh mesh;
  for (const cloth::Collider& collider : colliders)
    std::visit(
        [&](const auto& shape) {
          if constexpr (!std::is_same_v<std::decay_t<decltype(shape)>, cloth::PlaneCollider>)
            add(mesh, shape);
        },
        collider);
  mesh.solid_vertices = mesh.positions.size();
  for (const cloth::Collider& collider : colliders)
    if (const auto* plane = std::get_if<cloth::PlaneCollider>(&collider))
      add(mesh, *plane, centre, plane_extent_mm);
  return mesh;
}

struct PropRenderer::Gl {
  std::optional<GlProgram> program;
  GLuint array = 0, buffer = 0;
  ~Gl() {
    glDeleteBuffers(1, &buffer);
    glDeleteVertexArrays(1, &array);
  }
};

Result<std::unique_ptr<PropRenderer>> PropRenderer::create(bool encode_srgb) {
  auto program = GlProgram::build(shaders::prop_vert, shaders::prop_frag);
  if (!program) return std::unexpected(program.error());
  std::unique_ptr<PropRenderer> renderer(new PropRenderer());
  renderer->gl_ = std::make_unique<Gl>();
  renderer->gl_->program.emplace(std::move(*program));
  renderer->encode_srgb_ = encode_srgb;
  glGenVertexArrays(1, &renderer->gl_->array);
  glGenBuffers(1, &renderer->gl_->buffer);
  return renderer;
}

PropRenderer::~PropRenderer() = default;

void PropRenderer::update(const std::vector<cloth::Collider>& colliders,
                          const Eigen::Vector3f& centre, float plane_extent_mm) {
  const PropMesh mesh = prop_mesh(colliders, centre, plane_extent_mm);
  std::vector<float> packed;
  packed.reserve(mesh.positions.size() * 6);
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    packed.insert(packed.end(), mesh.positions[i].data(), mesh.positions[i].data() + 3);
    packed.insert(packed.end(), mesh.normals[i].data(), mesh.normals[i].data() + 3);
  }
  vertices_ = static_cast<int>(mesh.positions.size());
  solid_vertices_ = static_cast<int>(mesh.solid_vertices);
  glBindBuffer(GL_ARRAY_BUFFER, gl_->buffer);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(packed.size() * sizeof(float)),
               packed.data(), GL_DYNAMIC_DRAW);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
}

void PropRenderer::draw(const KnitFrame& frame) const {
  if (vertices_ == 0) return;
  const GlProgram& program = *gl_->program;
  program.use();
  set_matrix(program.uniform("u_view_projection"), frame.projection * frame.view);
  glUniform4fv(program.uniform("u_light"), 1, frame.light.data());
  glUniform1i(program.uniform("u_encode_srgb"), encode_srgb_ ? 1 : 0);
  glEnable(GL_DEPTH_TEST);
  glDepthMask(GL_TRUE);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  glBindVertexArray(gl_->array);
  glBindBuffer(GL_ARRAY_BUFFER, gl_->buffer);
  const auto stride = static_cast<GLsizei>(6 * sizeof(float));
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride,
                        reinterpret_cast<const void*>(3 * sizeof(float)));
  glUniform3fv(program.uniform("u_colour"), 1, kSolidColour.data());
  glDrawArrays(GL_TRIANGLES, 0, solid_vertices_);
  glUniform3fv(program.uniform("u_colour"), 1, kFloorColour.data());
  glDrawArrays(GL_TRIANGLES, solid_vertices_, vertices_ - solid_vertices_);
  glBindVertexArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
}

}  // namespace psrig::preview
