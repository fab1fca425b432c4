#include "chart_synthesis.h"

#include <algorithm>
#include <numeric>
#include <set>

#include <opencv2/core/utility.hpp>

#include "lattice_sampling.h"
#include "psrig/cloth/knit_gauge.h"

namespace psrig::analysis::inference {
namespace {

// Repeats of at most this many stitches are tried in every labelling.
constexpr int kExhaustiveCells = 4;
// Larger ones are improved a stitch at a time, each try a draft knitted
// anew, for at most this many rounds.
constexpr int kFlipRounds = 6;
// Tightness factors the yarn is tried at: loose, usual and tight knitwear
// (knit_gauge.h). The labelling search uses the usual one.
constexpr float kLoose = 1.25f, kUsual = 1.5f, kTight = 1.8f;

struct Trial {
  const cv::Mat& folded;
  Period period;
  float wale_mm, course_mm;
};

// The yarn a knit of this gauge has at this tightness: Munden's loop
// length from the gauge (l = K_w / wales = K_c / courses, averaged), tex
// from the tightness factor (sqrt(tex) = K l).
float yarn_for(const Trial& trial, float tightness) {
  const float loop_mm =
      0.5f * (cloth::kMundenWales * trial.wale_mm + cloth::kMundenCourses * trial.course_mm);
  const float root_tex = tightness * loop_mm;
  return cloth::yarn_diameter_from_tex(root_tex * root_tex);
}

cloth::StitchChart chart_of(Period period, const std::vector<cloth::Stitch>& cells) {
  cloth::StitchChart chart;
  chart.name = "inferred";
  chart.columns = period.columns;
  chart.rows = period.rows;
  chart.cells = cells;
  chart.colour_index.assign(cells.size(), 0);
  return chart;
}

std::optional<Synthesis> knit_and_match(const Trial& trial, const std::vector<cloth::Stitch>& cells,
                                        float tightness, bool draft = false) {
  Synthesis out;
  out.chart = chart_of(trial.period, cells);
  out.tightness = tightness;
  out.yarn_mm = yarn_for(trial, tightness);
  auto rendered = render_chart_repeat(out.chart, trial.wale_mm, trial.course_mm, out.yarn_mm,
                                      trial.folded.cols / trial.period.columns, draft);
  if (!rendered) return std::nullopt;
  out.match = circular_match(trial.folded, *rendered);
  return out;
}

void keep_better(std::optional<Synthesis>& best, std::optional<Synthesis> candidate) {
  if (candidate && (!best || candidate->match.score > best->match.score))
    best = std::move(candidate);
}

// The labelling knitted loose and tight too, then halfway between the
// best and its neighbours: the yarn's size changes the look as much as a
// stitch does.
void try_tightnesses(const Trial& trial, std::optional<Synthesis>& best, bool draft = false) {
  const std::vector<cloth::Stitch> cells = best->chart.cells;
  for (const float tightness : {kLoose, kUsual, kTight})
    if (tightness != best->tightness)
      keep_better(best, knit_and_match(trial, cells, tightness, draft));
  const float step = 0.5f * (kTight - kLoose) / 2;
  const float around = best->tightness;
  for (const float tightness : {around - step / 2, around + step / 2})
    if (tightness >= kLoose - step / 2 && tightness <= kTight + step / 2)
      keep_better(best, knit_and_match(trial, cells, tightness, draft));
}

// A labelling as a number, and the least of its cyclic shifts: shifted
// labellings knit the same cloth and match alike, so one of each is tried.
std::vector<cloth::Stitch> cells_of(Period period, unsigned mask) {
  std::vector<cloth::Stitch> cells;
  for (int i = 0; i < period.columns * period.rows; ++i)
    cells.push_back((mask >> i) & 1u ? cloth::Stitch::purl : cloth::Stitch::knit);
  return cells;
}
unsigned least_shift(Period period, unsigned mask) {
  unsigned least = mask;
  for (int dy = 0; dy < period.rows; ++dy)
    for (int dx = 0; dx < period.columns; ++dx) {
      unsigned shifted = 0;
      for (int row = 0; row < period.rows; ++row)
        for (int column = 0; column < period.columns; ++column)
          if ((mask >> (row * period.columns + column)) & 1u)
            shifted |= 1u << (((row + dy) % period.rows) * period.columns +
                              (column + dx) % period.columns);
      least = std::min(least, shifted);
    }
  return least;
}

std::optional<Synthesis> every_labelling(const Trial& trial) {
  const int cells = trial.period.columns * trial.period.rows;
  std::set<unsigned> tried;
  std::optional<Synthesis> best;
  for (unsigned mask = 0; mask < (1u << cells); ++mask)
    if (tried.insert(least_shift(trial.period, mask)).second)
      keep_better(best, knit_and_match(trial, cells_of(trial.period, mask), kUsual));
  return best;
}

// Knit or purl for each cell by the better correlation of its face with
// the lone knit and purl faces, the face read `down` samples lower: a
// stitch's look lies partly in the course below its face (the V's point,
// the purl bump) and partly in its own.
std::vector<cloth::Stitch> lone_labelling(const Trial& trial, const StitchTemplates& lone,
                                          int down) {
  const int n = lone.samples;
  const cv::Mat& f = trial.folded;
  cv::Mat shifted(f.size(), CV_32F);  // row r: the fold's row r + down
  for (int r = 0; r < f.rows; ++r)
    f.row(((r + down) % f.rows + f.rows) % f.rows).copyTo(shifted.row(r));
  std::vector<cloth::Stitch> labels;
  for (int row = 0; row < trial.period.rows; ++row)
    for (int column = 0; column < trial.period.columns; ++column) {
      cv::Mat face =
          shifted(cv::Rect(column * n, (trial.period.rows - 1 - row) * n, n, n)).clone();
      normalise(face);
      labels.push_back(face.dot(lone.knit) >= face.dot(lone.purl) ? cloth::Stitch::knit
                                                                  : cloth::Stitch::purl);
    }
  return labels;
}

// Each stitch flipped on its own (drafts, side by side); then every flip
// that helped applied together, kept if that helps more than the best
// single one. Rounds until no flip helps; after the first, only the
// stitches that helped and those next to a change are tried again.
void improve_by_flips(const Trial& trial, std::optional<Synthesis>& best) {
  const Period p = trial.period;
  const std::size_t cells = static_cast<std::size_t>(p.columns * p.rows);
  std::vector<bool> worth(cells, true);
  for (int round = 0; round < kFlipRounds && best; ++round) {
    std::vector<int> tried;
    for (std::size_t i = 0; i < cells; ++i)
      if (worth[i]) tried.push_back(static_cast<int>(i));
    std::vector<std::optional<Synthesis>> flipped(tried.size());
    const std::vector<cloth::Stitch> base = best->chart.cells;
    cv::parallel_for_(cv::Range(0, static_cast<int>(tried.size())), [&](const cv::Range& range) {
      for (int t = range.start; t < range.end; ++t) {
        std::vector<cloth::Stitch> trial_cells = base;
        auto& cell = trial_cells[static_cast<std::size_t>(tried[static_cast<std::size_t>(t)])];
        cell = cell == cloth::Stitch::knit ? cloth::Stitch::purl : cloth::Stitch::knit;
        flipped[static_cast<std::size_t>(t)] =
            knit_and_match(trial, trial_cells, best->tightness, true);
      }
    });
    std::vector<cloth::Stitch> together = base;
    std::optional<Synthesis> best_single;
    std::fill(worth.begin(), worth.end(), false);
    for (std::size_t t = 0; t < tried.size(); ++t) {
      const auto i = static_cast<std::size_t>(tried[t]);
      if (!flipped[t] || flipped[t]->match.score <= best->match.score) continue;
      together[i] = flipped[t]->chart.cells[i];
      worth[i] = true;
      keep_better(best_single, std::move(flipped[t]));
    }
    if (!best_single) break;
    std::optional<Synthesis> next = std::move(best_single);
    keep_better(next, knit_and_match(trial, together, best->tightness, true));
    best = std::move(next);
    for (int row = 0; row < p.rows; ++row)
      for (int column = 0; column < p.columns; ++column) {
        if (best->chart.at(column, row) == base[static_cast<std::size_t>(row * p.columns + column)])
          continue;
        for (const auto& [dx, dy] : {std::pair{0, 0}, {1, 0}, {-1, 0}, {0, 1}, {0, -1}})
          worth[static_cast<std::size_t>(((row + dy + p.rows) % p.rows) * p.columns +
                                         (column + dx + p.columns) % p.columns)] = true;
      }
  }
}

}  // namespace

Match circular_match(cv::Mat folded, cv::Mat rendered) {
  Match match;
  if (folded.size() != rendered.size() || !normalise(folded) || !normalise(rendered)) return match;
  cv::Mat a, b, product, correlation;
  cv::dft(folded, a, cv::DFT_COMPLEX_OUTPUT);
  cv::dft(rendered, b, cv::DFT_COMPLEX_OUTPUT);
  cv::mulSpectrums(a, b, product, 0, true);
  cv::dft(product, correlation, cv::DFT_INVERSE | cv::DFT_REAL_OUTPUT | cv::DFT_SCALE);
  double top = 0;
  cv::Point at;
  cv::minMaxLoc(correlation, nullptr, &top, nullptr, &at);
  match.score = top;
  match.shift_row = at.y;
  match.shift_col = at.x;
  return match;
}

bool needs_refining(Period period) {
  return period.columns * period.rows > kExhaustiveCells;
}

std::optional<Synthesis> first_labelling(const cv::Mat& folded, Period period, float wale_mm,
                                         float course_mm, const StitchTemplates& lone) {
  const Trial trial{folded, period, wale_mm, course_mm};
  std::optional<Synthesis> best;
  if (needs_refining(period)) {
    // Drafts from the lone faces read at, half a course below and half a
    // course above the faces.
    const int n = lone.samples;
    for (const int down : {0, n / 2, -n / 2})
      keep_better(best, knit_and_match(trial, lone_labelling(trial, lone, down), kUsual, true));
    return best;
  }
  best = every_labelling(trial);
  if (best) try_tightnesses(trial, best);
  return best;
}

std::optional<Synthesis> refine_labelling(const cv::Mat& folded, Period period, float wale_mm,
                                          float course_mm, Synthesis start) {
  const Trial trial{folded, period, wale_mm, course_mm};
  std::optional<Synthesis> best = std::move(start);
  try_tightnesses(trial, best, true);  // the flips at the yarn that fits
  improve_by_flips(trial, best);
  if (!best) return best;
  best = knit_and_match(trial, best->chart.cells, best->tightness);
  if (best) try_tightnesses(trial, best);
  return best;
}

}  // namespace psrig::analysis::inference
