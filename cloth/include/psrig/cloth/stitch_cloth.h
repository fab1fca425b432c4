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
// the courses and the wales (structural), across each stitch's diagonals
// (shear), and over two stitches (bending), with the knit's own features:
// - the balance interval (section 4.1.1): a loop can change its length by
//   a few percent with little resistance before the yarn itself is
//   stretched or compressed: within it a soft spring (in the implicit
//   step), at its ends a limit the yarn does not pass (strain limiting,
//   Provot 1995: each structural spring brought back within the interval
//   after the step);
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
  // Bending, carried by springs over two stitches, as a share of the
  // structural stiffness: a knit is limp.
  float bending_share = 0.05f;
  float balance_interval = 0.05f;  // +-5 % before the yarn itself gives (chen2003)
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
  };

 private:
  struct Solver;
  void collide(bool friction);

  StitchMesh mesh_;
  KnitMaterial material_;
  Eigen::Vector3f gravity_;
  float mass_ = 0;  // per vertex
  std::vector<bool> pinned_;
  std::vector<Eigen::Vector3f> pin_target_;
  std::vector<Eigen::Vector3f> previous_, velocity_;
  std::vector<Spring> springs_;
  // The structural springs again, in groups that share no vertex, for the
  // strain limit.
  std::vector<std::vector<Spring>> limited_;
  void limit_strain();
  std::unique_ptr<Solver> solver_;
  bool input_ = false;  // factored for one frame length and set of pins
};

}  // namespace psrig::cloth
