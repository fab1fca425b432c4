#include "psrig/cloth/woven_surface.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Geometry>

namespace psrig::cloth {

namespace {

constexpr float kDegree = std::numbers::pi_v<float> / 180;
// The visibility march's step, spacings: a sixth of a yarn's half width at
// the default gap.
constexpr float kMarchStep = 0.04f;
constexpr int kMaxMarchSteps = 6000;

int wrapped(int i, int n) {
  const int r = i % n;
  return r < 0 ? r + n : r;
}

}  // namespace

Result<WovenSurface> WovenSurface::make(const WeaveMatrix& weave, const YarnShape& shape,
                                        float warp_beta, float weft_beta) {
  if (weave.warps <= 0 || weave.wefts <= 0 ||
      weave.cells.size() != static_cast<std::size_t>(weave.warps * weave.wefts))
    return std::unexpected(bad_input({}, "weave", "the weave matrix is empty or malformed"));
  if (!(shape.gap_ratio >= 0 && shape.gap_ratio < 0.9f))
    return std::unexpected(bad_input({}, "gap_ratio", "the gap ratio must be in [0, 0.9)"));
  if (!(shape.inclination_deg > 0 && shape.inclination_deg <= 80))
    return std::unexpected(
        bad_input({}, "inclination_deg", "the inclination must be in (0, 80] degrees"));
  if (!(shape.section_edge_deg > 0 && shape.section_edge_deg <= 85))
    return std::unexpected(
        bad_input({}, "section_edge_deg", "the section's edge slope must be in (0, 85] degrees"));
  if (!(warp_beta >= 0 && weft_beta >= 0))
    return std::unexpected(bad_input({}, "beta", "the height scaling must not be negative"));

  WovenSurface surface;
  surface.shape_ = shape;
  surface.warps_ = weave.warps;
  surface.wefts_ = weave.wefts;
  surface.warp_beta_ = warp_beta;
  surface.weft_beta_ = weft_beta;
  surface.over_ = weave.cells;
  surface.half_width_ = (1 - shape.gap_ratio) / 2;
  const float edge = shape.section_edge_deg * kDegree;
  surface.section_radius_ = surface.half_width_ / std::sin(edge);
  surface.section_rise_ = surface.section_radius_ * (1 - std::cos(edge));
  surface.sin_u_ = std::sin(shape.inclination_deg * kDegree);
  surface.cos_u_ = std::cos(shape.inclination_deg * kDegree);

  // Each yarn's runs of crossings on one side, found cyclically.
  const auto runs_of = [](const std::vector<bool>& over) {
    const int n = static_cast<int>(over.size());
    std::vector<Run> runs(static_cast<std::size_t>(n));
    int first_change = -1;
    for (int k = 0; k < n; ++k)
      if (over[static_cast<std::size_t>(k)] != over[static_cast<std::size_t>(wrapped(k - 1, n))]) {
        first_change = k;
        break;
      }
    if (first_change < 0) {
      for (Run& run : runs)
        run = {0, static_cast<std::int16_t>(n), over[0], true};
      return runs;
    }
    int start = first_change;
    while (true) {
      int length = 1;
      while (length < n && over[static_cast<std::size_t>(wrapped(start + length, n))] ==
                               over[static_cast<std::size_t>(start)])
        ++length;
      for (int k = 0; k < length; ++k)
        runs[static_cast<std::size_t>(wrapped(start + k, n))] = {
            static_cast<std::int16_t>(start), static_cast<std::int16_t>(length),
            over[static_cast<std::size_t>(start)], false};
      start = wrapped(start + length, n);
      if (start == first_change) break;
    }
    return runs;
  };
  surface.warp_runs_.resize(weave.cells.size());
  surface.weft_runs_.resize(weave.cells.size());
  for (int warp = 0; warp < weave.warps; ++warp) {
    std::vector<bool> over(static_cast<std::size_t>(weave.wefts));
    for (int weft = 0; weft < weave.wefts; ++weft)
      over[static_cast<std::size_t>(weft)] = weave.warp_over(warp, weft);
    const std::vector<Run> runs = runs_of(over);
    for (int weft = 0; weft < weave.wefts; ++weft)
      surface.warp_runs_[static_cast<std::size_t>(weft * weave.warps + warp)] =
          runs[static_cast<std::size_t>(weft)];
  }
  for (int weft = 0; weft < weave.wefts; ++weft) {
    std::vector<bool> over(static_cast<std::size_t>(weave.warps));
    for (int warp = 0; warp < weave.warps; ++warp)
      over[static_cast<std::size_t>(warp)] = !weave.warp_over(warp, weft);
    const std::vector<Run> runs = runs_of(over);
    for (int warp = 0; warp < weave.warps; ++warp)
      surface.weft_runs_[static_cast<std::size_t>(weft * weave.warps + warp)] =
          runs[static_cast<std::size_t>(warp)];
  }

  // An arc over half-chord a at end slope u rises a tan(u / 2).
  const float half_tan = std::tan(shape.inclination_deg * kDegree / 2);
  float rise = 0, sag = 0;
  for (const std::vector<Run>* runs : {&surface.warp_runs_, &surface.weft_runs_})
    for (const Run& run : *runs)
      if (!run.flat)
        (run.over ? rise : sag) = std::max(run.over ? rise : sag, run.length / 2.0f * half_tan);
  const float beta = std::max(warp_beta, weft_beta);
  surface.top_ = beta * (rise + surface.section_rise_);
  surface.floor_ = -beta * sag;
  return surface;
}

WovenSurface::Profile WovenSurface::centre_line(const Run& run, int crossing, float along,
                                                int period) const {
  if (run.flat) return {};
  const float t = static_cast<float>(wrapped(crossing - run.start, period)) + along;
  const float a = run.length / 2.0f;
  const float d = t - a;
  const float radius = a / sin_u_;
  const float root = std::sqrt(std::max(radius * radius - d * d, 1e-12f));
  const float sign = run.over ? 1.0f : -1.0f;
  return {sign * (root - radius * cos_u_), sign * (-d / root)};
}

WovenSurface::Profile WovenSurface::section(float across) const {
  const float r = section_radius_;
  const float root = std::sqrt(std::max(r * r - across * across, 1e-12f));
  return {root - (r - section_rise_), -across / root};
}

YarnType WovenSurface::yarn_at(const Eigen::Vector2f& xy, int& warp, int& weft, float& fx,
                               float& fy) const {
  const float cx = std::floor(xy.x()), cy = std::floor(xy.y());
  fx = xy.x() - cx - 0.5f;
  fy = xy.y() - cy - 0.5f;
  warp = wrapped(static_cast<int>(cx), warps_);
  weft = wrapped(static_cast<int>(cy), wefts_);
  const bool in_warp = std::abs(fx) < half_width_;
  const bool in_weft = std::abs(fy) < half_width_;
  if (in_warp && in_weft)
    return over_[static_cast<std::size_t>(weft * warps_ + warp)] ? YarnType::warp : YarnType::weft;
  if (in_warp) return YarnType::warp;
  if (in_weft) return YarnType::weft;
  return YarnType::gap;
}

WovenPoint WovenSurface::point(const Eigen::Vector2f& xy) const {
  int warp = 0, weft = 0;
  float fx = 0, fy = 0;
  WovenPoint p;
  p.yarn = yarn_at(xy, warp, weft, fx, fy);
  if (p.yarn == YarnType::gap) {
    p.height = floor_;
    return p;
  }
  const std::size_t cell = static_cast<std::size_t>(weft * warps_ + warp);
  Eigen::Vector3f axis;
  if (p.yarn == YarnType::warp) {
    const Profile line = centre_line(warp_runs_[cell], weft, fy + 0.5f, wefts_);
    const Profile across = section(fx);
    p.height = warp_beta_ * (line.height + across.height);
    p.normal =
        Eigen::Vector3f(-warp_beta_ * across.slope, -warp_beta_ * line.slope, 1).normalized();
    axis = Eigen::Vector3f(0, 1, warp_beta_ * line.slope).normalized();
  } else {
    const Profile line = centre_line(weft_runs_[cell], warp, fx + 0.5f, warps_);
    const Profile across = section(fy);
    p.height = weft_beta_ * (line.height + across.height);
    p.normal =
        Eigen::Vector3f(-weft_beta_ * line.slope, -weft_beta_ * across.slope, 1).normalized();
    axis = Eigen::Vector3f(1, 0, weft_beta_ * line.slope).normalized();
  }
  const float psi = shape_.twist_deg * kDegree;
  p.orientation = (std::cos(psi) * axis + std::sin(psi) * p.normal.cross(axis)).normalized();
  return p;
}

float WovenSurface::height(const Eigen::Vector2f& xy) const {
  int warp = 0, weft = 0;
  float fx = 0, fy = 0;
  const YarnType yarn = yarn_at(xy, warp, weft, fx, fy);
  if (yarn == YarnType::gap) return floor_;
  const std::size_t cell = static_cast<std::size_t>(weft * warps_ + warp);
  if (yarn == YarnType::warp)
    return warp_beta_ *
           (centre_line(warp_runs_[cell], weft, fy + 0.5f, wefts_).height + section(fx).height);
  return weft_beta_ *
         (centre_line(weft_runs_[cell], warp, fx + 0.5f, warps_).height + section(fy).height);
}

bool WovenSurface::visible(const Eigen::Vector3f& from, const Eigen::Vector3f& direction) const {
  if (direction.z() <= 0) return false;
  const float horizontal = direction.head<2>().norm();
  const float dt = kMarchStep / std::max(horizontal, direction.z());
  for (int step = 1; step <= kMaxMarchSteps; ++step) {
    const Eigen::Vector3f p = from + (dt * static_cast<float>(step)) * direction;
    if (p.z() >= top_) return true;
    if (p.z() < height(p.head<2>()) - 1e-4f) return false;
  }
  return true;
}

std::optional<Eigen::Vector3f> WovenSurface::first_hit(const Eigen::Vector3f& origin,
                                                       const Eigen::Vector3f& direction) const {
  if (direction.z() >= 0) return std::nullopt;
  // Start where the ray comes down through the yarns' top.
  float t = origin.z() > top_ ? (top_ - origin.z()) / direction.z() : 0;
  const float horizontal = direction.head<2>().norm();
  const float dt = kMarchStep / std::max(horizontal, -direction.z());
  for (int step = 0; step <= kMaxMarchSteps; ++step, t += dt) {
    const Eigen::Vector3f p = origin + t * direction;
    if (p.z() > height(p.head<2>())) continue;
    // Between the last step above and this one below: bisect.
    float above = t - dt, below = t;
    for (int k = 0; k < 12; ++k) {
      const float mid = (above + below) / 2;
      const Eigen::Vector3f q = origin + mid * direction;
      (q.z() > height(q.head<2>()) ? above : below) = mid;
    }
    return origin + below * direction;
  }
  return std::nullopt;
}

}  // namespace psrig::cloth
