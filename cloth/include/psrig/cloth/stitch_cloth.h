#pragma once
// Knitted cloth in motion at stitch level: one mass per corner of the
// stitch mesh (stitch_mesh.h), springs between them, gravity, damping and
// colliders with friction. Each frame is an implicit Euler step, solved
// the way Liu, Bargteil, O'Brien and Kavan solve mass-spring systems ("Fast
// simulation of mass-spring systems", SIGGRAPH Asia 2013; projective
// dynamics, Bouaziz et al. 2014): alternately each spring's ideal
// direction and length (local, in parallel) and every mass's position from
// one sparse linear system whose matrix never changes (global, factored
// once). Implicit Euler is stable at any stiffness and frame rate and
// loses energy, never gains it; unlike position-based dynamics, the cloth's
// stretch is the material's, not the solver's.
//
// The springs are chen2003-lumislice-knitwear.txt's (section 4.1): along
// the courses and the wales (structural) and across each stitch's
// diagonals (shear), with the knit's own features below. Bending is not
// chen2003's spring over two stitches, which resists a uniform squeeze in
// the plane as much as a fold, so that cloth over a ball, with more
// material than the ball's surface, cannot gather: its corners stood out
// like wings. It is the flat cloth's curvature along each course and wale
// (the three-point Laplacian, linear in the positions: Bergou et al.,
// "Discrete quadratic curvature energies", 2006, for a flat rest shape),
// which a squeeze in the plane leaves untouched, so the cloth folds as
// cloth does, and the term sits in the constant matrix.
// - the balance interval (section 4.1.1): a loop can change its length by
//   a few percent with little resistance before the yarn itself is
//   stretched: within it a soft spring (in the implicit step), at its
//   stretched end a limit the yarn does not pass (strain limiting, Provot
//   1995: each structural spring brought back within the interval after
//   the step). Squeezed, cloth buckles rather than shortens its yarn, so
//   no limit holds it apart (one did, and pushed the cloth on a ball
//   outwards);
// - stiffness different along courses and wales: a knit stretches far more
//   across (the loops open) than along (the yarn straightens);
// - thickness (section 4.1.2): colliders keep the cloth half its thickness
//   away; friction (section 4.1.3) static below a threshold, dynamic above.
// No self-collision: the cloth can fold through itself.
//
// Every parallel loop works per spring or per mass, and the solve is one
// thread's, so a step's result does not depend on the number of threads.
//
// Units: millimetres, grams, seconds (forces in g mm/s^2, 1 uN).

#include <algorithm>
#include <memory>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "psrig/cloth/collider.h"
#include "psrig/cloth/stitch_mesh.h"

namespace psrig::cloth {

struct KnitMaterial {
  // Tensile stiffness per unit width within the balance interval, N/m:
  // force per metre of cloth for a strain of 1.
  float course_stiffness_n_per_m = 3;  // stretching across, along the courses
  float wale_stiffness_n_per_m = 15;   // along the wales
  float shear_stiffness_n_per_m = 0.5f;
  // Bending rigidity per unit width, uN m (KES-FB2's B: 1 gf cm^2/cm is
  // 98 uN m). Single jersey is limp, about 0.01-0.03 gf cm^2/cm, and bends
  // more readily across its courses than along its wales.
  float course_bending_un_m = 1.0f;  // bending the courses (the fold's axis along the wales)
  float wale_bending_un_m = 2.0f;
  float balance_interval = 0.05f;  // +-5 % before the yarn itself gives (chen2003)
  // A course or wale squeezed shorter by up to this share pushes back
  // with nothing: cloth buckles in wrinkles finer than a stitch rather than
  // shorten its yarn (Choi and Ko, "Stable but responsive cloth", 2002:
  // compression is buckling's business). Without it, cloth on a ball,
  // more of it than the ball's surface, stood out in a stiff cone.
  float free_squeeze = 0.2f;
  float areal_density_g_per_m2 = 220;
  float damping_per_s = 0.8f;  // air and inner friction: velocity lost per second, a share
  float static_friction = 0.6f, dynamic_friction = 0.4f;
  float thickness_mm = 1.0f;  // about two yarn diameters
};

struct ClothEnergy {
  double kinetic = 0, gravity = 0, elastic = 0;  // g mm^2/s^2 (nJ)
  [[nodiscard]] double total() const { return kinetic + gravity + elastic; }
};

class StitchCloth {
 public:
  // `rest` is the mesh at rest, laid where the scene wants it.
  StitchCloth(const StitchMesh& rest, const KnitMaterial& material,
              Eigen::Vector3f gravity = {0, 0, -9810});
  ~StitchCloth();
  StitchCloth(StitchCloth&&) noexcept;
  StitchCloth& operator=(StitchCloth&&) noexcept;

  // The vertex (column, row) held where it is (or moved by move_pinned()).
  void pin(int column, int row);
  void move_pinned(const Eigen::Vector3f& by);
  // The vertices marked (one per mesh vertex, row-major) taken out of the
  // cloth: every spring and bend that reaches one dropped, the vertex held
  // where it is, outside the cloth (a specimen cut to shape: Cusick's
  // circle from the rectangular mesh). Before the first step.
  void cut(const std::vector<bool>& removed);

  // Change them between steps; say so with note_input() when one moved.
  std::vector<Collider> colliders;
  // The scene did work on the cloth this frame (a collider moved): the
  // step may gain energy.
  void note_input() { input_ = true; }

  // One frame of `dt` seconds: `iterations` local-global rounds (more: the
  // step closer to exact implicit Euler).
  void step(float dt, int iterations = 4);

  // The cloth now, as a stitch mesh for the yarns to follow.
  [[nodiscard]] const StitchMesh& mesh() const { return mesh_; }
  [[nodiscard]] std::span<const Eigen::Vector3f> velocities() const { return velocity_; }
  [[nodiscard]] ClothEnergy energy() const;
  // Deepest any vertex is inside a collider, less the half-thickness (0: none).
  [[nodiscard]] float deepest_penetration() const;

  struct Spring {
    int a = 0, b = 0;
    float rest = 0;
    float stiffness = 0;  // g/s^2
    float slack = 0;      // the share of its length it gives up unresisted
    // The length it pulls towards from `length`: its rest, or anything
    // down to its slack's end when squeezed.
    [[nodiscard]] float relaxed(float length) const {
      return length >= rest ? rest : std::max(length, (1 - slack) * rest);
    }
  };

 private:
  struct Solver;
  void collide(bool friction);
  // The masses lying on a collider (within kResting of its surface, or in it).
  [[nodiscard]] std::vector<bool> resting() const;
  // How far `point` is from the nearest collider, less half the cloth's
  // thickness (negative: in it).
  [[nodiscard]] float clearance(const Eigen::Vector3f& point) const;
  // `point` pushed out of every collider, its slide along the surface
  // since `from` held back by friction.
  [[nodiscard]] Eigen::Vector3f held_on_surface(const Eigen::Vector3f& point,
                                                const Eigen::Vector3f& from) const;
  // `point` pushed out of every collider, half the cloth's thickness clear.
  [[nodiscard]] Eigen::Vector3f outside(const Eigen::Vector3f& point) const;

  StitchMesh mesh_;
  KnitMaterial material_;
  Eigen::Vector3f gravity_;
  float mass_ = 0;  // per vertex
  std::vector<bool> pinned_;
  std::vector<Eigen::Vector3f> pin_target_;
  std::vector<Eigen::Vector3f> previous_, velocity_;
  std::vector<Spring> springs_;
  // Three neighbours along a course or a wale, a-b-c, and the stiffness
  // of their curvature (a - 2b + c): the bending term.
  struct Bend {
    int a = 0, b = 0, c = 0;
    float stiffness = 0;  // g/s^2
  };
  std::vector<Bend> bends_;
  // The structural springs again, in groups that share no vertex, for the
  // strain limit.
  std::vector<std::vector<Spring>> limited_;
  void limit_strain();
  std::unique_ptr<Solver> solver_;
  bool input_ = false;  // factored for one frame length and set of pins
};

}  // namespace psrig::cloth
