#include "psrig/cloth/stitch_cloth.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <Eigen/SparseCholesky>

#include "psrig/base/parallel.h"

namespace psrig::cloth {
namespace {

constexpr float kNewtonPerMetre = 1000.0f;  // in g/s^2
constexpr float kMicronewtonMetre = 1000.0f;  // in g mm^2/s^2 (1 N m = 1e9)
// A pinned mass is held by a spring this many times stiffer than its
// inertia over a frame: fixed to well under a micrometre.
constexpr double kPinHold = 1e6;
// A mass on a collider is held to its surface this many times more
// firmly than its inertia over a frame: well under the cloth's thickness
// against the springs' pull.
constexpr double kContactHold = 1e4;
// A mass this close to a collider (mm beyond half the cloth's thickness)
// lies on it.
constexpr float kResting = 0.05f;

}  // namespace

// The global step's matrix, factored, for one frame length and set of pins.
struct StitchCloth::Solver {
  float frame = 0;
  double inertia = 0;  // m / h^2
  double pin_stiffness = 0;
  double contact_stiffness = 0;
  Eigen::SparseMatrix<float> matrix;  // without contact
  std::vector<bool> touching;         // the contacts `factor` holds
  int steps_since_factored = 0;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<float>> factor;
  // Per vertex, its springs: index and which end it is (+1: a, -1: b).
  std::vector<std::vector<std::pair<int, float>>> incident;
};

StitchCloth::StitchCloth(const StitchMesh& rest, const KnitMaterial& material,
                         Eigen::Vector3f gravity)
    : mesh_(rest), material_(material), gravity_(gravity) {
  const int columns = rest.columns + 1, rows = rest.rows + 1;  // vertices
  const auto index = [&](int column, int row) { return row * columns + column; };
  const std::size_t count = rest.vertices.size();
  const float w = rest.face_width_mm, c = rest.face_height_mm;
  mass_ = material.areal_density_g_per_m2 * 1e-6f * w * c;
  pinned_.assign(count, false);
  pin_target_ = rest.vertices;
  previous_ = rest.vertices;
  velocity_.assign(count, Eigen::Vector3f::Zero());

  // Stiffness per unit strain and width, as springs: a course spring of
  // length w carries a strip c wide, a wale spring of length c one w wide.
  const float course_k = material.course_stiffness_n_per_m * kNewtonPerMetre * c / w;
  const float wale_k = material.wale_stiffness_n_per_m * kNewtonPerMetre * w / c;
  const float shear_k = material.shear_stiffness_n_per_m * kNewtonPerMetre;
  const auto spring = [&](int a, int b, float k) {
    const float length = (rest.vertices[static_cast<std::size_t>(a)] -
                          rest.vertices[static_cast<std::size_t>(b)])
                             .norm();
    return Spring{a, b, length, k};
  };
  const auto add = [&](int a, int b, float k, float slack = 0) {
    Spring made = spring(a, b, k);
    made.slack = slack;
    springs_.push_back(made);
  };
  limited_.resize(4);  // course springs from even and odd columns, wale ones from even and odd rows
  for (int row = 0; row < rows; ++row)
    for (int column = 0; column < columns; ++column) {
      const int here = index(column, row);
      if (column + 1 < columns) add(here, index(column + 1, row), course_k, material.free_squeeze);
      if (row + 1 < rows) add(here, index(column, row + 1), wale_k, material.free_squeeze);
      // Curvature a - 2b + c over spacing h is a bend of (a - 2b + c)/h^2;
      // its energy B/2 kappa^2 over the strip's width and length h gives
      // the stiffness B width / h^3.
      if (column + 2 < columns)
        bends_.push_back({here, index(column + 1, row), index(column + 2, row),
                          material.course_bending_un_m * kMicronewtonMetre * c / (w * w * w)});
      if (row + 2 < rows)
        bends_.push_back({here, index(column, row + 1), index(column, row + 2),
                          material.wale_bending_un_m * kMicronewtonMetre * w / (c * c * c)});
      if (column + 1 < columns)
        limited_[static_cast<std::size_t>(column % 2)].push_back(
            spring(here, index(column + 1, row), course_k));
      if (row + 1 < rows)
        limited_[static_cast<std::size_t>(2 + row % 2)].push_back(
            spring(here, index(column, row + 1), wale_k));
      if (column + 1 < columns && row + 1 < rows) {
        add(here, index(column + 1, row + 1), shear_k);
        add(index(column + 1, row), index(column, row + 1), shear_k);
      }
    }
}

StitchCloth::~StitchCloth() = default;
StitchCloth::StitchCloth(StitchCloth&&) noexcept = default;
StitchCloth& StitchCloth::operator=(StitchCloth&&) noexcept = default;

void StitchCloth::pin(int column, int row) {
  const auto i = static_cast<std::size_t>(row * (mesh_.columns + 1) + column);
  pinned_[i] = true;
  pin_target_[i] = mesh_.vertices[i];
  solver_.reset();
}

void StitchCloth::move_pinned(const Eigen::Vector3f& by) {
  for (std::size_t i = 0; i < pinned_.size(); ++i)
    if (pinned_[i]) pin_target_[i] += by;
  input_ = true;
}

void StitchCloth::cut(const std::vector<bool>& removed) {
  const auto out = [&](int v) { return removed[static_cast<std::size_t>(v)]; };
  const auto reaches = [&](const Spring& spring) { return out(spring.a) || out(spring.b); };
  std::erase_if(springs_, reaches);
  for (std::vector<Spring>& group : limited_)
    std::erase_if(group, reaches);
  std::erase_if(bends_,
                [&](const Bend& bend) { return out(bend.a) || out(bend.b) || out(bend.c); });
  for (std::size_t i = 0; i < removed.size(); ++i)
    if (removed[i]) {
      pinned_[i] = true;
      pin_target_[i] = mesh_.vertices[i];
    }
  solver_.reset();
}

void StitchCloth::step(float dt, int iterations) {
  const std::size_t count = mesh_.vertices.size();
  const double h = dt;
  if (!solver_ || solver_->frame != dt) {
    auto solver = std::make_unique<Solver>();
    solver->frame = dt;
    solver->inertia = mass_ / (h * h);
    solver->pin_stiffness = kPinHold * solver->inertia;
    solver->incident.assign(count, {});
    std::vector<Eigen::Triplet<float>> entries;
    for (std::size_t i = 0; i < count; ++i)
      entries.emplace_back(static_cast<int>(i), static_cast<int>(i),
                           solver->inertia + (pinned_[i] ? solver->pin_stiffness : 0.0));
    for (std::size_t s = 0; s < springs_.size(); ++s) {
      const Spring& spring = springs_[s];
      const double k = spring.stiffness;
      entries.emplace_back(spring.a, spring.a, k);
      entries.emplace_back(spring.b, spring.b, k);
      entries.emplace_back(spring.a, spring.b, -k);
      entries.emplace_back(spring.b, spring.a, -k);
      solver->incident[static_cast<std::size_t>(spring.a)].emplace_back(static_cast<int>(s), 1.0f);
      solver->incident[static_cast<std::size_t>(spring.b)].emplace_back(static_cast<int>(s), -1.0f);
    }
    // The bend's k |a - 2b + c|^2 / 2 is quadratic with its minimum at
    // zero: all of it in the matrix, nothing to project.
    for (const Bend& bend : bends_) {
      const std::array<int, 3> at{bend.a, bend.b, bend.c};
      constexpr std::array<double, 3> weight{1, -2, 1};
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          entries.emplace_back(at[static_cast<std::size_t>(i)], at[static_cast<std::size_t>(j)],
                               bend.stiffness * weight[static_cast<std::size_t>(i)] *
                                   weight[static_cast<std::size_t>(j)]);
    }
    solver->matrix.resize(static_cast<Eigen::Index>(count), static_cast<Eigen::Index>(count));
    solver->matrix.setFromTriplets(entries.begin(), entries.end());
    solver->contact_stiffness = kContactHold * solver->inertia;
    solver->touching.assign(count, false);
    solver->factor.analyzePattern(solver->matrix);
    solver->factor.factorize(solver->matrix);
    solver_ = std::move(solver);
  }
  Solver& solver = *solver_;

  // Masses lying on a collider are held there inside the solve (Bouaziz et
  // al. 2014's collision constraints): contact applied only after the
  // solve put back a mass the solve had drawn into the collider where it
  // touched, losing the springs' pull along the surface (the sphere
  // scene's hanging sides drew the cloth on the ball's top 8 mm in a step,
  // and its stitches there crept apart to 4x their length in 3 s). The
  // matrix is refactored when that set changes (only its diagonal does);
  // a factorisation costs a few steps (30 ms at 10 K stitches), so a small
  // change waits up to 8 steps, the masses that arrived meanwhile met by
  // the contact after the solve, as all were before.
  const std::vector<bool> touching = resting();
  std::size_t changed = 0;
  for (std::size_t i = 0; i < count; ++i) changed += touching[i] != solver.touching[i];
  ++solver.steps_since_factored;
  if (changed > 0 && (changed > count / 100 || solver.steps_since_factored >= 8)) {
    solver.steps_since_factored = 0;
    Eigen::SparseMatrix<float> held = solver.matrix;
    for (std::size_t i = 0; i < count; ++i)
      if (touching[i]) held.coeffRef(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(i)) +=
          static_cast<float>(solver.contact_stiffness);
    solver.factor.factorize(held);
    solver.touching = touching;
  }

  std::vector<Eigen::Vector3f>& x = mesh_.vertices;
  const double energy_before = energy().total();
  previous_ = x;
  // Where inertia and gravity alone would take each mass. The rounds
  // start from where the motion alone would: a frame's fall (0.7 mm at
  // 120 Hz) is half a stitch, and springs' directions taken after it
  // were so far off that four rounds settled a short overhang with a kink
  // at its edge, holding 27 times the work gravity had done in bending.
  Eigen::MatrixX3d inertial(static_cast<Eigen::Index>(count), 3);
  for (std::size_t i = 0; i < count; ++i) {
    const Eigen::Vector3f y = x[i] + dt * velocity_[i] + dt * dt * gravity_;
    inertial.row(static_cast<Eigen::Index>(i)) = y.cast<double>().transpose();
    if (!pinned_[i]) x[i] += dt * velocity_[i];
  }
  std::vector<Eigen::Vector3f> pulled(springs_.size());  // k times the spring's target vector
  Eigen::MatrixX3d rhs(static_cast<Eigen::Index>(count), 3);
  for (int iteration = 0; iteration < std::max(iterations, 1); ++iteration) {
    psrig::parallel_chunks(static_cast<int>(springs_.size()), 4096, [&](int begin, int end) {
      for (int s = begin; s < end; ++s) {
        const Spring& spring = springs_[static_cast<std::size_t>(s)];
        const Eigen::Vector3f d =
            x[static_cast<std::size_t>(spring.a)] - x[static_cast<std::size_t>(spring.b)];
        const float length = d.norm();
        pulled[static_cast<std::size_t>(s)] =
            length > 1e-9f ? Eigen::Vector3f(spring.stiffness * spring.relaxed(length) / length * d)
                           : Eigen::Vector3f::Zero();
      }
    });
    psrig::parallel_chunks(static_cast<int>(count), 2048, [&](int begin, int end) {
      for (int i = begin; i < end; ++i) {
        const auto v = static_cast<std::size_t>(i);
        Eigen::Vector3d b = solver.inertia * inertial.row(i).transpose();
        for (const auto& [s, sign] : solver.incident[v])
          b += (sign * pulled[static_cast<std::size_t>(s)]).cast<double>();
        if (pinned_[v]) b += solver.pin_stiffness * pin_target_[v].cast<double>();
        if (solver.touching[v]) {
          // Lying on a collider: held where it lies, pushed out of it, so
          // that the springs pull it along the surface, not into it, and
          // with friction (the same rule as after the solve, the depth
          // the iterate went in standing for the normal force). Held by
          // the factorisation but off the collider now (a change not yet
          // refactored): where its motion and gravity take it.
          b += solver.contact_stiffness *
               (touching[v] ? held_on_surface(x[v], previous_[v]).cast<double>()
                            : Eigen::Vector3d(inertial.row(i).transpose()));
        }
        rhs.row(i) = b.transpose();
      }
    });
    const Eigen::MatrixX3f solved = solver.factor.solve(rhs.cast<float>());
    for (std::size_t i = 0; i < count; ++i)
      x[i] = solved.row(static_cast<Eigen::Index>(i)).transpose().cast<float>();
  }
  // Friction acts on the step's motion; the strain limit then pulls what
  // friction held too far, and contact has the last word.
  collide(true);
  limit_strain();
  collide(false);
  const float keep = std::max(0.0f, 1.0f - material_.damping_per_s * dt);
  for (std::size_t i = 0; i < count; ++i)
    velocity_[i] = pinned_[i] ? Eigen::Vector3f::Zero() : Eigen::Vector3f(keep * (x[i] - previous_[i]) / dt);
  // A few local-global rounds are not the exact implicit step, which never
  // gains energy; what they gain is taken back from the motion (the energy
  // budget of Dinev, Liu and Kavan, "Stabilizing integrators for real-time
  // physics", TOG 2018). Not when the scene moved the cloth this frame.
  if (!input_) {
    const ClothEnergy after = energy();
    const double gained = after.total() - energy_before;
    if (gained > 0 && after.kinetic > 0) {
      const auto scale = static_cast<float>(std::sqrt(std::max(0.0, 1 - gained / after.kinetic)));
      for (Eigen::Vector3f& v : velocity_) v *= scale;
    }
  }
  input_ = false;
}

// Each structural spring brought back to at most the balance interval's
// stretch, a few passes over groups that share no vertex (Provot's strain
// limit).
void StitchCloth::limit_strain() {
  constexpr int kPasses = 4;
  const float play = material_.balance_interval;
  std::vector<Eigen::Vector3f>& x = mesh_.vertices;
  for (int pass = 0; pass < kPasses; ++pass)
    for (const std::vector<Spring>& group : limited_)
      psrig::parallel_chunks(static_cast<int>(group.size()), 1024, [&](int begin, int end) {
        for (int s = begin; s < end; ++s) {
          const Spring& spring = group[static_cast<std::size_t>(s)];
          const auto a = static_cast<std::size_t>(spring.a), b = static_cast<std::size_t>(spring.b);
          const float wa = pinned_[a] ? 0.0f : 1.0f, wb = pinned_[b] ? 0.0f : 1.0f;
          if (wa + wb == 0) continue;
          const Eigen::Vector3f d = x[a] - x[b];
          const float length = d.norm();
          const float target = std::min(length, (1 + play) * spring.rest);
          if (length == target || length < 1e-9f) continue;
          const Eigen::Vector3f move = (length - target) / (length * (wa + wb)) * d;
          x[a] -= wa * move;
          x[b] += wb * move;
        }
      });
}

std::vector<bool> StitchCloth::resting() const {
  std::vector<bool> on(mesh_.vertices.size(), false);
  if (colliders.empty()) return on;
  for (std::size_t v = 0; v < on.size(); ++v)
    on[v] = !pinned_[v] && clearance(mesh_.vertices[v]) < kResting;
  return on;
}

float StitchCloth::clearance(const Eigen::Vector3f& point) const {
  float clear = std::numeric_limits<float>::infinity();
  for (const Collider& collider : colliders)
    clear = std::min(clear, nearest_surface(collider, point).distance - 0.5f * material_.thickness_mm);
  return clear;
}

Eigen::Vector3f StitchCloth::held_on_surface(const Eigen::Vector3f& point,
                                             const Eigen::Vector3f& from) const {
  const Eigen::Vector3f out = outside(point);
  const float depth = (out - point).norm();
  if (depth == 0) return out;
  const Eigen::Vector3f normal = (out - point) / depth;
  const Eigen::Vector3f moved = out - from;
  const Eigen::Vector3f sliding = moved - moved.dot(normal) * normal;
  const float slide = sliding.norm();
  if (slide < material_.static_friction * depth) return out - sliding;
  return out - sliding * std::min(material_.dynamic_friction * depth / slide, 1.0f);
}

Eigen::Vector3f StitchCloth::outside(const Eigen::Vector3f& point) const {
  const float half = 0.5f * material_.thickness_mm;
  Eigen::Vector3f out = point;
  for (const Collider& collider : colliders) {
    const SurfacePoint surface = nearest_surface(collider, out);
    if (surface.distance < half) out += (half - surface.distance) * surface.normal;
  }
  return out;
}

void StitchCloth::collide(bool friction) {
  const float half = 0.5f * material_.thickness_mm;
  std::vector<Eigen::Vector3f>& x = mesh_.vertices;
  psrig::parallel_chunks(static_cast<int>(x.size()), 1024, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      const auto v = static_cast<std::size_t>(i);
      if (pinned_[v]) continue;
      for (const Collider& collider : colliders) {
        // A fast mass could pass a thin collider within one frame: follow
        // its path from where it was (out of the collider, which may have
        // moved onto it) and stop it where it first touched.
        Eigen::Vector3f start = previous_[v];
        const SurfacePoint was = nearest_surface(collider, start);
        if (was.distance < half) start += (half - was.distance) * was.normal;
        const Eigen::Vector3f path = x[v] - start;
        const float travel = path.norm();
        const float clear = nearest_surface(collider, start).distance - half;
        if (clear > -1e-4f && clear < travel) {
          const int samples = std::min(64, static_cast<int>(std::ceil(2 * travel / half)));
          x[v] = start + path;
          for (int k = 1; k <= samples; ++k) {
            const Eigen::Vector3f at = start + (static_cast<float>(k) / static_cast<float>(samples)) * path;
            if (nearest_surface(collider, at).distance < half) {
              x[v] = at;
              break;
            }
          }
        }
        const SurfacePoint surface = nearest_surface(collider, x[v]);
        const float depth = half - surface.distance;
        if (depth <= 0) continue;
        x[v] += depth * surface.normal;
        if (!friction) continue;
        // Friction on this frame's sliding along the surface: held while it
        // is below the static threshold, slowed by the dynamic one above.
        const Eigen::Vector3f moved = x[v] - previous_[v];
        const Eigen::Vector3f sliding = moved - moved.dot(surface.normal) * surface.normal;
        const float slide = sliding.norm();
        if (slide < material_.static_friction * depth) {
          x[v] -= sliding;
        } else if (slide > 0) {
          x[v] -= sliding * std::min(material_.dynamic_friction * depth / slide, 1.0f);
        }
      }
    }
  });
}

ClothEnergy StitchCloth::energy() const {
  ClothEnergy energy;
  const std::vector<Eigen::Vector3f>& x = mesh_.vertices;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (pinned_[i]) continue;
    energy.kinetic += 0.5 * mass_ * velocity_[i].squaredNorm();
    energy.gravity -= mass_ * gravity_.dot(x[i]);
  }
  for (const Spring& spring : springs_) {
    const float length =
        (x[static_cast<std::size_t>(spring.a)] - x[static_cast<std::size_t>(spring.b)]).norm();
    const double stretch = length - spring.relaxed(length);
    energy.elastic += 0.5 * spring.stiffness * stretch * stretch;
  }
  for (const Bend& bend : bends_) {
    const Eigen::Vector3f curve = x[static_cast<std::size_t>(bend.a)] -
                                  2 * x[static_cast<std::size_t>(bend.b)] +
                                  x[static_cast<std::size_t>(bend.c)];
    energy.elastic += 0.5 * bend.stiffness * curve.squaredNorm();
  }
  return energy;
}

float StitchCloth::deepest_penetration() const {
  const float half = 0.5f * material_.thickness_mm;
  float deepest = 0;
  for (const Eigen::Vector3f& v : mesh_.vertices)
    for (const Collider& collider : colliders)
      deepest = std::max(deepest, half - nearest_surface(collider, v).distance);
  return deepest;
}

}  // namespace psrig::cloth
