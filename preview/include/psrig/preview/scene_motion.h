#pragma once
// The kiosk's motion, as a function of time so any frame can be drawn (or
// tested) on its own: the light orbits the swatch, and the model sways
// gently, spinning up when given a kick (a new scan has landed) and braking
// back to the sway (VirTex: auto-rotation with automatic braking).

#include "psrig/preview/scene_view.h"

namespace psrig::preview {

struct MotionParams {
  double light_orbit_deg_per_s = 36;  // one turn in 10 s
  double sway_amplitude_deg = 20;     // model yaw either way
  double sway_period_s = 16;
  double brake_per_s = 0.8;  // a kick's spin decays as exp(-brake * t)
};

class SceneMotion {
 public:
  explicit SceneMotion(MotionParams params = {}) : params_(params) {}

  // Spins the model up by `deg_per_s` at time `now_s` (seconds, the same
  // clock as at()); the spin brakes by itself.
  void kick(double now_s, double deg_per_s);
  // `base` with the light's tilt and the model's yaw moved to time `now_s`.
  [[nodiscard]] SceneView at(double now_s, SceneView base) const;
  // The kick's spin still left at `now_s`, degrees per second.
  [[nodiscard]] double spin(double now_s) const;

 private:
  MotionParams params_;
  double kick_time_s_ = 0;
  double kick_speed_ = 0;   // at kick_time_s_
  double kick_offset_ = 0;  // yaw the earlier kicks had turned by kick_time_s_
};

}  // namespace psrig::preview
