#include "psrig/cloth/knit_fabric.h"

#include <cmath>
#include <numbers>
#include <random>

#include "psrig/cloth/yarn_spline.h"
#include "psrig/processing/parallel.h"

namespace psrig::cloth {
namespace {

// Rest layout of one stitch in face coordinates (u across, v up; the
// stitch's face is [0, 1]^2). The knots sit a quarter in from each side, a
// little above the face's bottom edge; their half length spans the contacts.
constexpr float kKnotU = 0.24f;
// Both yarns cross a knot leaning toward the stitch's middle, so the legs
// between the feet and the head open upward into the knit's V.
constexpr float kKnotLean = 0.45f;  // radians
constexpr float kKnotV = 0.18f;
constexpr float kKnotHalfLength = 0.16f;  // in course heights
constexpr float kSinkerV = 0.05f;
constexpr float kHeadV = 0.45f;  // in the face above

float loop_sign(const KnitLayout& layout, int column, int row) {
  return layout.is_purl(column, row) ? -1.0f : 1.0f;  // knit: +1
}

}  // namespace

KnitLayout tile_chart(const StitchChart& chart, int columns, int rows) {
  KnitLayout layout{columns, rows, {}, {}};
  layout.purl.reserve(static_cast<std::size_t>(columns * rows));
  for (int row = 0; row < rows; ++row)
    for (int column = 0; column < columns; ++column) {
      layout.purl.push_back(chart.at(column, row) == Stitch::purl ? 1 : 0);
      if (!chart.palette.empty())
        layout.colours.push_back(
            chart.palette[static_cast<std::size_t>(chart.colour_at(column, row))]);
    }
  return layout;
}

KnitFabric KnitFabric::build(const KnitLayout& layout, const KnitParameters& parameters) {
  KnitFabric fabric;
  fabric.layout_ = layout;
  fabric.parameters_ = parameters;
  const int columns = layout.columns, rows = layout.rows;
  const float half_length = kKnotHalfLength * parameters.course_height_mm;
  std::mt19937 random(parameters.seed);
  std::uniform_real_distribution<float> jitter(-parameters.variation, parameters.variation);

  fabric.knots_.resize(static_cast<std::size_t>(2 * columns * (rows + 1)));
  for (int face_row = 0; face_row <= rows; ++face_row)
    for (int column = 0; column < columns; ++column)
      for (const bool right : {false, true}) {
        RestKnot& knot = fabric.knots_[fabric.knot_index(column, face_row, right)];
        knot.u = (right ? 1 - kKnotU : kKnotU) + jitter(random);
        knot.v = kKnotV + jitter(random);
        // Both yarns run up through a left knot and down through a right one.
        knot.state = {(right ? -0.5f : 0.5f) * std::numbers::pi_v<float> +
                          (right ? kKnotLean : -kKnotLean) + jitter(random),
                      half_length * (1 + jitter(random))};
        // The feet's loop decides which yarn lies in front at which contact;
        // above the last course, the head's own loop does.
        const float s = loop_sign(layout, column, std::min(face_row, rows - 1));
        const float sigma = right ? -1.0f : 1.0f;
        if (face_row < rows) {  // the feet of course face_row
          KnotPass& feet = knot.passes[static_cast<std::size_t>(knot.pass_count)];
          feet.side = 1;
          feet.lift_enter = -sigma * s;
          feet.lift_leave = sigma * s;
          knot.pass_course[static_cast<std::size_t>(knot.pass_count++)] = face_row;
        }
        if (face_row > 0) {  // the head of course face_row - 1
          KnotPass& head = knot.passes[static_cast<std::size_t>(knot.pass_count)];
          head.side = -1;
          head.lift_enter = sigma * s;
          head.lift_leave = -sigma * s;
          knot.pass_course[static_cast<std::size_t>(knot.pass_count++)] = face_row - 1;
        }
      }
  for (int row = 0; row < rows; ++row) {
    for (int column = 0; column <= columns; ++column) {
      // Sinkers lie behind the loops below for knit, in front for purl; between a
      // knit and a purl loop, halfway.
      const float s = 0.5f * (loop_sign(layout, std::max(column - 1, 0), row) +
                              loop_sign(layout, std::min(column, columns - 1), row));
      fabric.sinkers_.push_back({std::min(column, columns - 1), row,
                                 (column == columns ? 1.0f : 0.0f), kSinkerV + jitter(random), -s});
    }
    for (int column = 0; column < columns; ++column) {
      // A head lies behind the legs of a knit loop above it, before a purl's.
      const float s = loop_sign(layout, column, std::min(row + 1, rows - 1));
      fabric.heads_.push_back(
          {column, row + 1, 0.5f + jitter(random), kHeadV + jitter(random), -s});
    }
  }

  // The rest shape: the template on the undeformed mesh.
  const StitchMesh rest = fabric.mesh();
  fabric.place(rest);
  for (std::size_t k = 0; k < fabric.knots_.size(); ++k)
    fabric.initial_[k] = fabric.knots_[k].state;
  fabric.link_passes(rest);
  for (std::size_t k = 0; k < fabric.knots_.size(); ++k) {
    RestKnot& knot = fabric.knots_[k];
    for (int p = 0; p < knot.pass_count; ++p) {
      KnotPass& pass = knot.passes[static_cast<std::size_t>(p)];
      record_rest_shape(pass, knot_points(fabric.placements_[k], knot.state, pass));
    }
  }
  fabric.states_ = fabric.initial_;
  return fabric;
}

StitchMesh KnitFabric::mesh(ClothDeformation deformation) const {
  return make_stitch_mesh(layout_.columns, layout_.rows + 1, parameters_.stitch_width_mm,
                          parameters_.course_height_mm, parameters_.shape, deformation);
}

std::span<const KnotPass> KnitFabric::passes(int knot) const {
  const RestKnot& rest = knots_[static_cast<std::size_t>(knot)];
  return {rest.passes.data(), static_cast<std::size_t>(rest.pass_count)};
}

Eigen::Vector3f KnitFabric::fixed_position(const StitchMesh& mesh, const FixedPoint& point) const {
  // The face's frame as place() found it this update: both knots of a face share it.
  const FaceFrame& frame = face_frame(point.column, point.face_row);
  return mesh.point(point.column, point.face_row, point.u, point.v) +
         point.lift * parameters_.style.radius_mm * frame.normal;
}

// Knot centres follow the mesh; the initial guess carries each knot's rest
// direction and half length through its face's deformation gradient.
void KnitFabric::place(const StitchMesh& mesh) {
  placements_.resize(knots_.size());
  initial_.resize(knots_.size());
  const int columns = layout_.columns;
  processing::parallel_chunks(layout_.rows + 1, 8, [&](int begin, int end) {
    for (int face_row = begin; face_row < end; ++face_row)
      for (int column = 0; column < columns; ++column) {
        const FaceFrame frame = mesh.frame(column, face_row);
        const Eigen::Matrix2f gradient = mesh.deformation_gradient(column, face_row, frame);
        for (const bool right : {false, true}) {
          const auto k = static_cast<std::size_t>(knot_index(column, face_row, right));
          const RestKnot& rest = knots_[k];
          placements_[k] = {mesh.point(column, face_row, rest.u, rest.v), frame,
                            parameters_.style.radius_mm};
          const Eigen::Vector2f direction =
              gradient * Eigen::Vector2f(std::cos(rest.state.theta), std::sin(rest.state.theta));
          initial_[k] = {std::atan2(direction.y(), direction.x()),
                         rest.state.half_length * direction.norm()};
        }
      }
  });
}

// Fills each pass's fixed neighbours: sinkers and head tops from the mesh,
// the neighbouring knots' points at their initial guess (so that every knot
// relaxes on its own, in parallel).
void KnitFabric::link_passes(const StitchMesh& mesh) {
  const int columns = layout_.columns, rows = layout_.rows;
  const auto pass_of = [&](int column, int face_row, bool right, int course) -> KnotPass& {
    RestKnot& knot = knots_[static_cast<std::size_t>(knot_index(column, face_row, right))];
    return knot.passes[knot.pass_course[0] == course ? 0 : 1];
  };
  const auto points_of = [&](int column, int face_row, bool right, int course) {
    const auto k = static_cast<std::size_t>(knot_index(column, face_row, right));
    return knot_points(placements_[k], initial_[k], pass_of(column, face_row, right, course));
  };
  processing::parallel_chunks(rows, 8, [&](int begin, int end) {
    for (int row = begin; row < end; ++row)
      for (int column = 0; column < columns; ++column) {
        const Eigen::Vector3f sinker =
            fixed_position(mesh, sinkers_[static_cast<std::size_t>(row * (columns + 1) + column)]);
        const Eigen::Vector3f next_sinker = fixed_position(
            mesh, sinkers_[static_cast<std::size_t>(row * (columns + 1) + column + 1)]);
        const Eigen::Vector3f head =
            fixed_position(mesh, heads_[static_cast<std::size_t>(row * columns + column)]);
        KnotPass& feet_left = pass_of(column, row, false, row);
        KnotPass& head_left = pass_of(column, row + 1, false, row);
        KnotPass& head_right = pass_of(column, row + 1, true, row);
        KnotPass& feet_right = pass_of(column, row, true, row);
        feet_left.before = sinker;
        feet_left.after = points_of(column, row + 1, false, row).enter;
        head_left.before = points_of(column, row, false, row).leave;
        head_left.after = head;
        head_right.before = head;
        head_right.after = points_of(column, row, true, row).enter;
        feet_right.before = points_of(column, row + 1, true, row).leave;
        feet_right.after = next_sinker;
      }
  });
}

void KnitFabric::update(const StitchMesh& mesh, YarnSet& yarns, bool relax) {
  place(mesh);
  link_passes(mesh);
  states_.resize(knots_.size());
  const int count = static_cast<int>(knots_.size());
  processing::parallel_chunks(count, 256, [&](int begin, int end) {
    const auto chunk = static_cast<std::size_t>(end - begin);
    if (!relax) {
      std::copy_n(initial_.begin() + begin, chunk, states_.begin() + begin);
      return;
    }
    std::vector<KnotProblem> problems;
    problems.reserve(chunk);
    for (int k = begin; k < end; ++k)
      problems.push_back({&placements_[static_cast<std::size_t>(k)], passes(k),
                          initial_[static_cast<std::size_t>(k)]});
    relax_knots(problems, parameters_.iterations, parameters_.weights,
                std::span(states_).subspan(static_cast<std::size_t>(begin), chunk));
  });
  sample(mesh, yarns);
}

void KnitFabric::sample(const StitchMesh& mesh, YarnSet& yarns) const {
  const int columns = layout_.columns, rows = layout_.rows;
  yarns.style = parameters_.style;
  yarns.curves.resize(static_cast<std::size_t>(rows));
  const int per_span = std::max(parameters_.samples_per_span, 1);
  processing::parallel_chunks(rows, 4, [&](int begin, int end) {
    std::vector<YarnControlPoint> control;
    for (int row = begin; row < end; ++row) {
      control.clear();
      const auto colour = [&](int column) -> Eigen::Vector3f {
        return layout_.colours.empty()
                   ? Eigen::Vector3f::Zero()
                   : layout_.colours[static_cast<std::size_t>(row * columns + column)];
      };
      const auto fixed = [&](const FixedPoint& point, int column) {
        control.push_back({fixed_position(mesh, point),
                           face_frame(point.column, point.face_row).normal, point.lift,
                           colour(column)});
      };
      const auto knot = [&](int column, int face_row, bool right) {
        const auto k = static_cast<std::size_t>(knot_index(column, face_row, right));
        const RestKnot& rest = knots_[k];
        const KnotPass& pass = rest.passes[rest.pass_course[0] == row ? 0 : 1];
        const KnotPoints points = knot_points(placements_[k], states_[k], pass);
        const Eigen::Vector3f& normal = placements_[k].frame.normal;
        control.push_back({points.enter, normal, pass.lift_enter, colour(column)});
        control.push_back({points.beside, normal, 0.0f, colour(column)});
        control.push_back({points.leave, normal, pass.lift_leave, colour(column)});
      };
      for (int column = 0; column < columns; ++column) {
        fixed(sinkers_[static_cast<std::size_t>(row * (columns + 1) + column)], column);
        knot(column, row, false);
        knot(column, row + 1, false);
        fixed(heads_[static_cast<std::size_t>(row * columns + column)], column);
        knot(column, row + 1, true);
        knot(column, row, true);
      }
      fixed(sinkers_[static_cast<std::size_t>(row * (columns + 1) + columns)], columns - 1);

      sample_yarn(control, per_span, !layout_.colours.empty(),
                  yarns.curves[static_cast<std::size_t>(row)]);
    }
  });
}

}  // namespace psrig::cloth
