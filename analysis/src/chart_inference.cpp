#include "psrig/analysis/chart_inference.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>

#include <opencv2/imgproc.hpp>

#include "chart_synthesis.h"
#include "lattice_sampling.h"
#include "psrig/analysis/colour_palette.h"
#include "psrig/analysis/stitch_templates.h"
#include "stitch_period.h"
#include "working_square.h"

namespace psrig::analysis {
namespace {

using inference::Period;
using inference::RepeatFrame;
using inference::Split;
using inference::StitchBlock;

// A stitch narrower or shorter than this many pixels shows no loop shape.
constexpr double kMinStitchPx = 6;
// Course spacing over wale spacing: garter's ridges crowd to about 0.5,
// a 1x1 rib's drawn-in wales stretch to about 1.3; knits lie well inside.
constexpr double kMinAspect = 0.35;
constexpr double kMaxAspect = 2.0;
// Lone faces are rendered at aspects this factor apart (the nearest serves).
constexpr double kAspectRatioStep = 1.25;
// Splits of the measured repeat checked by knitting their chart: those of
// at most this many stitches, and the others whose lone-stitch fit ranks
// this high. A stitch's neighbours change its look (a 1x1 rib's purl wales
// hide behind its knit ones, garter's courses crowd), which the lone knit
// and purl faces do not show, so the best lone fit can be a wrong split.
constexpr int kSmallSplit = 4;
constexpr int kBestLoneFits = 2;
// Below this correlation with its knitted chart the maps look like no knit:
// the cloth model's own charts fit 0.90 to 0.99, an egg-crate of round
// bumps 0.60 (chart_inference_test.cpp). Real knits, which the model only
// approximates, may fit lower; untried on real scans yet.
constexpr double kMinFit = 0.7;
// The wale spacing lone faces are rendered at (only the aspect matters: the
// yarn follows the loop at the usual tightness).
constexpr float kTemplateWaleMm = 1.4f;

int wrap(int value, int period) {
  return ((value % period) + period) % period;
}

// Normalised correlation of `tmpl` with every n x n window of the periodic
// `folded` (top-left corner at each sample): the size of `folded`.
cv::Mat correlation(const cv::Mat& folded, const cv::Mat& tmpl) {
  const int n = tmpl.rows;
  cv::Mat padded;
  cv::copyMakeBorder(folded, padded, 0, n - 1, 0, n - 1, cv::BORDER_WRAP);
  cv::Mat out;
  cv::matchTemplate(padded, tmpl, out, cv::TM_CCOEFF_NORMED);
  return out;
}

// Lone knit and purl faces, rendered once per aspect step.
class TemplateBank {
 public:
  explicit TemplateBank(int samples) : samples_(samples) {}
  const StitchTemplates* at(double aspect) {
    const int step = static_cast<int>(std::lround(std::log(aspect) / std::log(kAspectRatioStep)));
    auto found = bank_.find(step);
    if (found == bank_.end()) {
      auto rendered = render_stitch_templates(
          kTemplateWaleMm, static_cast<float>(kTemplateWaleMm * std::pow(kAspectRatioStep, step)),
          samples_);
      if (!rendered) return nullptr;  // no knit has stitches of this shape
      found = bank_.emplace(step, std::move(*rendered)).first;
    }
    return &found->second;
  }

 private:
  int samples_;
  std::map<int, StitchTemplates> bank_;
};

// One way the stitches may lie: a split of the measured repeat and the
// phase the lone faces fit best at.
struct Candidate {
  Split split;
  StitchLattice lattice;
  double lone_fit = 0;
  const StitchTemplates* templates = nullptr;
};

// Every split of the measured repeat, each at its best phase: the mean over
// the repeat's faces of the better of the knit and purl correlations. The
// repeat is folded once, finely, and resampled for each split.
std::vector<Candidate> candidate_splits(const cv::Mat& height, cv::Rect window,
                                        const RepeatFrame& measured, int max_split, int n,
                                        const ChartInferenceOptions& options, TemplateBank& bank) {
  const double area = std::abs(cross(measured.u, measured.w));
  const double across = area / norm(measured.w);  // across the wales
  const double up = area / norm(measured.u);      // across the course lines
  // Three samples a pixel along each direction: finer than any split needs
  // (a face of n samples is at least kMinStitchPx pixels).
  const Split fine{std::max(1, static_cast<int>(std::ceil(3 * norm(measured.u)))),
                   std::max(1, static_cast<int>(std::ceil(3 * norm(measured.w))))};
  const cv::Mat finely = inference::fold(height, window, measured, fine, 1);
  std::vector<Candidate> candidates;
  for (int k = 1; k <= max_split; ++k)
    for (int k2 = 1; k2 <= max_split; ++k2) {
      if ((options.known_wales_per_repeat > 0 && k != options.known_wales_per_repeat) ||
          (options.known_courses_per_repeat > 0 && k2 != options.known_courses_per_repeat))
        continue;
      const double wale_px = across / k, course_px = up / k2;
      const double aspect = course_px / wale_px;
      if (wale_px < kMinStitchPx || course_px < kMinStitchPx || aspect < kMinAspect ||
          aspect > kMaxAspect)
        continue;
      const StitchTemplates* templates = bank.at(aspect);
      if (!templates) continue;
      const Split split{k, k2};
      cv::Mat folded;
      cv::resize(finely, folded, cv::Size(k * n, k2 * n), 0, 0, cv::INTER_AREA);
      const cv::Mat best =
          cv::max(correlation(folded, templates->knit), correlation(folded, templates->purl));
      Candidate candidate{split, {}, -2, templates};
      int phase_row = 0, phase_col = 0;
      for (int pr = 0; pr < n; ++pr)
        for (int pc = 0; pc < n; ++pc) {
          double total = 0;
          for (int i = 0; i < k2; ++i)
            for (int j = 0; j < k; ++j)
              total += best.at<float>(pr + i * n, pc + j * n);
          if (const double fit = total / (k * k2); fit > candidate.lone_fit) {
            candidate.lone_fit = fit;
            phase_row = pr;
            phase_col = pc;
          }
        }
      // The folded face at (phase_row, phase_col) is the top-left stitch's.
      const cv::Point2d corner = measured.at(static_cast<double>(phase_col) / (k * n),
                                             -static_cast<double>(phase_row) / (k2 * n));
      candidate.lattice = {corner, measured.u / k, measured.w / k2};
      candidates.push_back(candidate);
    }
  std::sort(candidates.begin(), candidates.end(),
            [](const Candidate& a, const Candidate& b) { return a.lone_fit > b.lone_fit; });
  return candidates;
}

// Which splits to check by rendering: every small one (a measured repeat
// mostly holds one to four stitches, since knit and purl faces look alike
// enough for the autocorrelation to repeat at the stitches), then the best
// lone fits.
std::vector<Candidate> shortlist(std::vector<Candidate> all) {
  std::vector<Candidate> chosen;
  for (const Candidate& c : all)
    if (c.split.wales * c.split.courses <= kSmallSplit) chosen.push_back(c);
  int added = 0;
  for (const Candidate& c : all)
    if (c.split.wales * c.split.courses > kSmallSplit && added++ < kBestLoneFits)
      chosen.push_back(c);
  return chosen;
}

// Millimetres per pixel for knitting: the maps' own, else a plain knit's
// wale spacing over this lattice's.
double render_scale(const StitchLattice& lattice, const FabricMeasurement& fabric) {
  return fabric.pixel_size_mm.value_or(kTemplateWaleMm / norm(lattice.next_wale_px));
}

// One candidate taken through: the repeat of its stitches (from the faces
// and colours alone), the maps folded onto it, and the labelling whose
// knitted repeat matches that best.
struct Reading {
  Candidate candidate;
  StitchBlock block;
  Period period;
  cv::Mat folded;
  float wale_mm = 0, course_mm = 0;
  inference::Synthesis synthesis;
};

std::optional<Reading> read_candidate(const cv::Mat& height, const cv::Mat& albedo, cv::Rect window,
                                      const Candidate& candidate,
                                      const FabricMeasurement& fabric, int max_period,
                                      int n) {
  const StitchBlock block = inference::inner_stitches(candidate.lattice, height.size());
  if (block.columns < 2 || block.rows < 2) return std::nullopt;
  Period period =
      inference::face_period(inference::faces_of(height, block, n), block.columns, block.rows,
                             max_period);
  if (!albedo.empty()) {
    const ColourPalette palette = quantise_colours(inference::colours_of(albedo, block, n));
    period = inference::common_period(
        period, inference::colour_period(palette.index, block.columns, block.rows, max_period));
  }
  if (period.columns > max_period || period.rows > max_period) return std::nullopt;
  const RepeatFrame repeat{block.lattice.origin_px, period.columns * block.lattice.next_wale_px,
                           period.rows * block.lattice.next_course_px};
  const cv::Mat folded = inference::fold(height, window, repeat, {period.columns, period.rows}, n);
  const double mm = render_scale(block.lattice, fabric);
  const auto [wale_px, course_px] = inference::spacing(block.lattice);
  const auto wale_mm = static_cast<float>(wale_px * mm), course_mm = static_cast<float>(course_px * mm);
  auto synthesis =
      inference::first_labelling(folded, period, wale_mm, course_mm, *candidate.templates);
  if (!synthesis) return std::nullopt;
  return Reading{candidate, block, period, folded, wale_mm, course_mm, std::move(*synthesis)};
}

std::string describe(int columns, int rows) {
  return std::to_string(columns) + " x " + std::to_string(rows);
}

// Each stitch on its own: knit or purl as the repeat cell whose folded face
// (its neighbours' effect included) it correlates with best; where its face
// has holes, the chart's.
std::vector<cloth::Stitch> read_stitches(const std::vector<cv::Mat>& faces, int columns,
                                         const cv::Mat& folded, const cloth::StitchChart& chart,
                                         int n) {
  std::vector<std::pair<cv::Mat, cloth::Stitch>> cells;
  for (int row = 0; row < chart.rows; ++row)
    for (int column = 0; column < chart.columns; ++column) {
      cv::Mat face = folded(cv::Rect(column * n, (chart.rows - 1 - row) * n, n, n)).clone();
      if (inference::normalise(face)) cells.emplace_back(face, chart.at(column, row));
    }
  std::vector<cloth::Stitch> stitches;
  for (std::size_t i = 0; i < faces.size(); ++i) {
    double best = -2;
    const int index = static_cast<int>(i);
    cloth::Stitch stitch = chart.at(index % columns, index / columns);
    for (const auto& [cell, kind] : cells)
      if (!faces[i].empty() && faces[i].dot(cell) > best) {
        best = faces[i].dot(cell);
        stitch = kind;
      }
    stitches.push_back(stitch);
  }
  return stitches;
}

// Each repeat cell's most common palette entry over the grid.
void colour_chart(cloth::StitchChart& chart, const std::vector<std::uint8_t>& index, int columns,
                  int rows) {
  const std::size_t entries = std::max<std::size_t>(1, chart.palette.size());
  std::vector<std::vector<int>> votes(chart.cells.size(), std::vector<int>(entries, 0));
  for (int row = 0; row < rows; ++row)
    for (int column = 0; column < columns; ++column)
      ++votes[static_cast<std::size_t>(wrap(row, chart.rows) * chart.columns +
                                       wrap(column, chart.columns))]
             [index[static_cast<std::size_t>(row * columns + column)]];
  for (std::size_t cell = 0; cell < votes.size(); ++cell)
    chart.colour_index[cell] = static_cast<std::uint8_t>(
        std::max_element(votes[cell].begin(), votes[cell].end()) - votes[cell].begin());
}

// What a chart is read from: knitted maps with a measured repeat, their
// height, and an albedo (when there is one) that matches it.
Status check_chart_inputs(const cv::Mat& height, const cv::Mat& albedo,
                          const FabricMeasurement& fabric) {
  using analysis::Construction;
  if (fabric.construction == Construction::woven && fabric.construction_from_metadata)
    return std::unexpected(bad_input(
        {}, "fabric.construction",
        "the scan is woven (scan.json's fabric.construction): a stitch chart is read from "
        "knitted fabric only"));
  if (!fabric.periodic)
    return std::unexpected(bad_input(
        {}, "fabric",
        "no repeat was measured on the maps (" +
            (fabric.notes.empty() ? std::string("no repeat found") : fabric.notes.back()) +
            "); the stitches are found within the measured repeat"));
  if (height.empty() || height.channels() != 1)
    return std::unexpected(bad_input({}, "height", "a stitch chart needs the height map"));
  if (!albedo.empty() && (albedo.size() != height.size() || albedo.depth() != CV_32F ||
                          (albedo.channels() != 3 && albedo.channels() != 1)))
    return std::unexpected(bad_input(
        {}, "albedo", "the albedo must be float, grey or BGR, and the size of the height map"));
  return {};
}

// The best first reading, refined when its repeat is large (its first
// labelling was only the lone faces' reading); refined, it must still
// beat the others.
std::optional<Reading> choose_reading(const std::vector<std::optional<Reading>>& readings) {
  const auto better = [](const std::optional<Reading>& a, const std::optional<Reading>& b) {
    return a && (!b || a->synthesis.match.score > b->synthesis.match.score);
  };
  std::optional<Reading> best;
  for (const auto& reading : readings)
    if (better(reading, best)) best = reading;
  if (best && inference::needs_refining(best->period)) {
    auto refined = inference::refine_labelling(best->folded, best->period, best->wale_mm,
                                               best->course_mm, best->synthesis);
    if (refined) best->synthesis = std::move(*refined);
    for (const auto& reading : readings)
      if (reading && !inference::needs_refining(reading->period) && better(reading, best))
        best = reading;
  }
  return best;
}

// Why the maps gave no chart: the best fit, short of a knit's.
Error poor_fit(const std::optional<Reading>& best, const FabricMeasurement& fabric) {
  char text[400];
  std::snprintf(text, sizeof text,
                "the maps' stitches look like no knitted chart (best fit %.2f; knitted fabric "
                "fits %.2f or more)%s",
                best ? best->synthesis.match.score : 0.0, kMinFit,
                fabric.construction == Construction::woven
                    ? ": the measurement takes it for woven (give scan.json's "
                      "fabric.construction if it is knitted)"
                    : ": is it knitted?");
  return bad_input({}, "height", text);
}

// The stitches' reading: every split of the measured repeat at its best
// phase, the likeliest knitted and matched, the best kept where it fits as
// knitted fabric does.
Result<Reading> best_reading(const cv::Mat& height, const cv::Mat& albedo, cv::Rect window,
                             const RepeatFrame& measured, const FabricMeasurement& fabric,
                             const ChartInferenceOptions& options, TemplateBank& bank) {
  const int n = options.samples;
  std::vector<Candidate> candidates =
      candidate_splits(height, window, measured, options.max_stitches_per_repeat, n, options, bank);
  if (candidates.empty())
    return std::unexpected(bad_input({}, "fabric.lattice_px",
                                     "the measured repeat is too small to hold a stitch of " +
                                         std::to_string(static_cast<int>(kMinStitchPx)) +
                                         " pixels or more"));
  // Each candidate knitted and matched on its own, side by side.
  const std::vector<Candidate> checked = shortlist(std::move(candidates));
  std::vector<std::optional<Reading>> readings(checked.size());
  cv::parallel_for_(cv::Range(0, static_cast<int>(checked.size())), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i)
      readings[static_cast<std::size_t>(i)] =
          read_candidate(height, albedo, window, checked[static_cast<std::size_t>(i)], fabric,
                         options.max_stitches_per_repeat, n);
  });
  std::optional<Reading> best = choose_reading(readings);
  if (!best || best->synthesis.match.score < kMinFit)
    return std::unexpected(poor_fit(best, fabric));
  return std::move(*best);
}

// The share of the stitches, each read on its own, that agree with the chart
// tiled over the grid.
double chart_agreement(const InferredKnit& out) {
  int agree = 0;
  for (int row = 0; row < out.rows; ++row)
    for (int column = 0; column < out.columns; ++column)
      agree += out.stitches[static_cast<std::size_t>(row * out.columns + column)] ==
               out.chart.at(column, row);
  return out.stitches.empty() ? 0.0 : static_cast<double>(agree) / out.stitches.size();
}

// The stitches where the knitted chart fits best: the lattice moved by
// the match's shift, so that chart cell (0, 0) lies at lattice stitch
// (0, 0); then started at the maps' bottom-left whole stitch. The chart,
// each stitch read on its own, and the colours.
InferredKnit knit_of(const Reading& reading, const cv::Mat& height, const cv::Mat& albedo,
                     cv::Rect window, const ChartInferenceOptions& options) {
  const int n = options.samples;
  const Period period = reading.period;
  const inference::Match& match = reading.synthesis.match;
  StitchLattice lattice = reading.block.lattice;
  lattice.origin_px = lattice.corner(static_cast<double>(match.shift_col) / n,
                                     -static_cast<double>(match.shift_row) / n);
  const StitchBlock block = inference::inner_stitches(lattice, height.size());
  InferredKnit out;
  out.columns = block.columns;
  out.rows = block.rows;
  out.lattice = block.lattice;
  cloth::StitchChart& chart = out.chart;
  chart.name = "inferred";
  chart.columns = period.columns;
  chart.rows = period.rows;
  for (int row = 0; row < period.rows; ++row)
    for (int column = 0; column < period.columns; ++column)
      chart.cells.push_back(
          reading.synthesis.chart.at(column + block.first.x, row + block.first.y));
  chart.colour_index.assign(chart.cells.size(), 0);

  const RepeatFrame repeat{block.lattice.origin_px, period.columns * block.lattice.next_wale_px,
                           period.rows * block.lattice.next_course_px};
  const cv::Mat folded = inference::fold(height, window, repeat, {period.columns, period.rows}, n);
  out.stitches =
      read_stitches(inference::faces_of(height, block, n), block.columns, folded, chart, n);
  if (!albedo.empty()) {
    out.colours = inference::colours_of(albedo, block, n);
    ColourPalette palette = quantise_colours(out.colours);
    chart.palette = std::move(palette.colours);
    out.colour_index = std::move(palette.index);
    colour_chart(chart, out.colour_index, out.columns, out.rows);
  }
  out.fit = match.score;
  out.split_from_scan = options.known_wales_per_repeat > 0 || options.known_courses_per_repeat > 0;
  out.wales_per_repeat = reading.candidate.split.wales;
  out.courses_per_repeat = reading.candidate.split.courses;
  out.agreement = chart_agreement(out);
  return out;
}

// Densities as fabric_measure.h counts them, one wale and course per stitch,
// the chart's gauge where the pixel size is known, and the notes.
void add_gauge_and_notes(InferredKnit& out, const Reading& reading,
                         const FabricMeasurement& fabric) {
  cloth::StitchChart& chart = out.chart;
  const auto [wale_px, course_px] = inference::spacing(out.lattice);
  out.per_pixel = !fabric.pixel_size_mm;
  const double unit = fabric.pixel_size_mm ? 10.0 / *fabric.pixel_size_mm : 1.0;
  out.wales_per_cm = unit / wale_px;
  out.courses_per_cm = unit / course_px;
  if (!out.per_pixel) {
    chart.gauge.wales_per_cm = static_cast<float>(out.wales_per_cm);
    chart.gauge.courses_per_cm = static_cast<float>(out.courses_per_cm);
    // The yarn the knitted chart matched best with: an estimate, to the
    // tightness factor's steps.
    chart.gauge.yarn_diameter_mm = reading.synthesis.yarn_mm;
  }
  char text[400];
  std::snprintf(text, sizeof text,
                "stitches: %s to a measured repeat; chart %s (wales x courses), fit %.2f with "
                "the chart as the cloth model knits it (yarn %.2f mm); %d x %d stitches seen, "
                "%.1f %% of them, each read on its own, agree with the chart",
                describe(reading.candidate.split.wales, reading.candidate.split.courses).c_str(),
                describe(reading.period.columns, reading.period.rows).c_str(), out.fit,
                reading.synthesis.yarn_mm, out.columns, out.rows, 100 * out.agreement);
  out.notes.emplace_back(text);
  if (out.per_pixel)
    out.notes.emplace_back("no pixel size: the gauge is per pixel and the chart has none");
}

}  // namespace

Result<InferredKnit> infer_knit_chart(const cv::Mat& height_in, const cv::Mat& albedo,
                                      const FabricMeasurement& fabric,
                                      const ChartInferenceOptions& options) {
  if (auto ok = check_chart_inputs(height_in, albedo, fabric); !ok)
    return std::unexpected(ok.error());
  const int n = options.samples;
  cv::Mat height;
  height_in.convertTo(height, CV_32F);
  const int side_x = std::min(height.cols, kMaxWorkingSide);
  const int side_y = std::min(height.rows, kMaxWorkingSide);
  const cv::Rect window((height.cols - side_x) / 2, (height.rows - side_y) / 2, side_x, side_y);
  const RepeatFrame measured{
      {window.x + 0.5 * side_x, window.y + 0.5 * side_y}, fabric.u_px, -fabric.v_px};

  TemplateBank bank(n);
  const auto reading = best_reading(height, albedo, window, measured, fabric, options, bank);
  if (!reading) return std::unexpected(reading.error());
  InferredKnit out = knit_of(*reading, height, albedo, window, options);
  add_gauge_and_notes(out, *reading, fabric);
  return out;
}

ChartInferenceOptions options_from_scan(const FabricMeasurement& fabric,
                                        const FabricHints& hints) {
  ChartInferenceOptions options;
  if (hints.across_per_repeat > 0 && hints.along_per_repeat > 0) {
    options.known_wales_per_repeat = fabric.threads_u;
    options.known_courses_per_repeat = fabric.threads_v;
  }
  return options;
}

void count_stitches(FabricMeasurement& fabric, const InferredKnit& knit) {
  fabric.threads_u = knit.wales_per_repeat;
  fabric.threads_v = knit.courses_per_repeat;
  fabric.across_density = knit.wales_per_cm;
  fabric.along_density = knit.courses_per_cm;
  std::erase_if(fabric.notes, [](const std::string& note) {
    return note.starts_with("knit structure not given");
  });
  fabric.notes.push_back((knit.split_from_scan ? "stitches to the repeat as scan.json counts them, "
                                                "their knit and purl read off the maps: "
                                              : "stitches counted on the maps (chart inference): ") +
                         describe(knit.wales_per_repeat, knit.courses_per_repeat) +
                         " wales x courses to the repeat");
}

double agreement_with_chart(const std::vector<cloth::Stitch>& grid, int columns, int rows,
                            const cloth::StitchChart& chart) {
  if (grid.empty() || chart.cells.empty()) return 0;
  int best = 0;
  for (int dy = 0; dy < chart.rows; ++dy)
    for (int dx = 0; dx < chart.columns; ++dx) {
      int agree = 0;
      for (int row = 0; row < rows; ++row)
        for (int column = 0; column < columns; ++column)
          agree += grid[static_cast<std::size_t>(row * columns + column)] ==
                   chart.at(column + dx, row + dy);
      best = std::max(best, agree);
    }
  return static_cast<double>(best) / static_cast<double>(grid.size());
}

bool same_chart_up_to_shift(const cloth::StitchChart& a, const cloth::StitchChart& b) {
  if (a.columns != b.columns || a.rows != b.rows) return false;
  for (int dy = 0; dy < b.rows; ++dy)
    for (int dx = 0; dx < b.columns; ++dx) {
      bool same = true;
      for (int row = 0; row < a.rows && same; ++row)
        for (int column = 0; column < a.columns && same; ++column)
          same = a.at(column, row) == b.at(column + dx, row + dy);
      if (same) return true;
    }
  return false;
}

}  // namespace psrig::analysis
