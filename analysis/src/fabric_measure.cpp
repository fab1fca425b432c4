#include "psrig/analysis/fabric_measure.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "plane_vectors.h"
#include "working_square.h"

namespace psrig::analysis {
namespace {

constexpr double kDeg = 180.0 / std::numbers::pi;
// A texture repeats when the autocorrelation has a peak off zero this high.
constexpr double kMinPeak = 0.25;
// Lattice candidates: peaks within this fraction of the highest. Lower peaks
// are partial matches (a V-stitch's two legs half a wale apart, a twill's
// floats one thread apart) and would give a sub-period.
constexpr double kCandidateFraction = 0.6;
// The fabric's directions lie within this of the image axes (the swatch is
// laid square on the rig, give or take a few degrees and a knit's spirality).
constexpr double kAxisConeDeg = 15.0;
// Detail below this fraction of a map's level is rounding, not texture.
constexpr double kNoDetail = 1e-5;
// How much better than a lattice vector its multiple must match for the
// vector to be taken for a sub-period of the repeat the scan counts.
constexpr double kWholeRepeatGain = 0.1;
// The most threads scan.json's fabric may say one repeat holds.
constexpr std::int64_t kMaxThreads = 1000;

// One channel as a float image with NaN where it has no value.
cv::Mat luminance(const cv::Mat& image) {
  cv::Mat f;
  image.convertTo(f, CV_32F,
                  image.depth() == CV_8U    ? 1.0 / 255
                  : image.depth() == CV_16U ? 1.0 / 65535
                                            : 1.0);
  if (f.channels() == 1) return f;
  cv::Mat grey;
  cv::transform(f, grey, cv::Matx<float, 1, 3>(1.0f / 3, 1.0f / 3, 1.0f / 3));
  return grey;
}

// Zero-mean, unit-variance detail: the map minus its low frequencies (a
// wavelength of a sixth of the image and up), zero where there is no value.
// `weight` gets 1 where the map has a value.
cv::Mat detail_of(const cv::Mat& map, cv::Mat& weight) {
  cv::Mat valid = map == map;  // NaN compares unequal
  cv::Mat values = map.clone();
  values.setTo(0, ~valid);
  valid.convertTo(weight, CV_32F, 1.0 / 255);
  const int side = std::min(map.cols, map.rows);
  const double step = std::max(1.0, side / 24.0);
  const cv::Size small(std::max(2, static_cast<int>(map.cols / step)),
                       std::max(2, static_cast<int>(map.rows / step)));
  cv::Mat vs, ws;
  cv::resize(values, vs, small, 0, 0, cv::INTER_AREA);
  cv::resize(weight, ws, small, 0, 0, cv::INTER_AREA);
  cv::GaussianBlur(vs, vs, cv::Size(0, 0), 1.0);
  cv::GaussianBlur(ws, ws, cv::Size(0, 0), 1.0);
  cv::Mat low = vs / cv::max(ws, 1e-6);
  cv::resize(low, low, map.size(), 0, 0, cv::INTER_LINEAR);
  cv::Mat out = (values - low).mul(weight);
  const double n = std::max(1.0, cv::sum(weight)[0]);
  const double rms = std::sqrt(out.dot(out) / n);
  // A map without detail (a uniform albedo) leaves only the resampling's
  // rounding, whose autocorrelation has peaks a few pixels apart: no detail.
  const double level = std::sqrt(values.dot(values) / n);
  if (!(rms > kNoDetail * level)) return cv::Mat::zeros(map.size(), CV_32F);
  out /= rms;
  return out;
}

cv::Mat autocorrelation(const cv::Mat& f, cv::Size padded) {
  cv::Mat big = cv::Mat::zeros(padded, CV_32F);
  f.copyTo(big(cv::Rect(0, 0, f.cols, f.rows)));
  cv::Mat spectrum, power, acf;
  cv::dft(big, spectrum);
  cv::mulSpectrums(spectrum, spectrum, power, 0, true);
  cv::dft(power, acf, cv::DFT_INVERSE | cv::DFT_REAL_OUTPUT | cv::DFT_SCALE);
  return acf;
}

// The normalised autocorrelation of the maps' detail, lag (0, 0) at the
// centre: (2 ly + 1) rows by (2 lx + 1) columns.
struct LagMap {
  cv::Mat rho;  // CV_32F
  int lx = 0, ly = 0;
  [[nodiscard]] float at(int dx, int dy) const { return rho.at<float>(dy + ly, dx + lx); }
  [[nodiscard]] bool inside(int dx, int dy, int margin) const {
    return std::abs(dx) <= lx - margin && std::abs(dy) <= ly - margin;
  }
};

struct Peak {
  cv::Point2d lag;
  double rho = 0;
};

// Local maxima (5x5) off the central lobe, one of each +-pair.
std::vector<Peak> peaks_of(const LagMap& map) {
  cv::Mat dilated;
  cv::dilate(map.rho, dilated, cv::getStructuringElement(cv::MORPH_RECT, {5, 5}));
  std::vector<Peak> peaks;
  for (int dy = 0; dy <= map.ly - 2; ++dy) {
    for (int dx = -map.lx + 2; dx <= map.lx - 2; ++dx) {
      if (dy == 0 && dx <= 0) continue;
      if (dx * dx + dy * dy < 9) continue;
      const float v = map.at(dx, dy);
      if (v > 0.1f && v >= dilated.at<float>(dy + map.ly, dx + map.lx))
        peaks.push_back({{static_cast<double>(dx), static_cast<double>(dy)}, v});
    }
  }
  return peaks;
}

// The normalised autocorrelation of the maps' detail, each map weighed by
// how well it repeats by itself (the square of its own highest peak off
// zero): a map that does not repeat (an albedo of randomly phased ply
// stripes on a plain-coloured knit) has no say in where the lattice lies,
// which, averaged in equally, it could pull by pixels.
LagMap lag_map(const std::vector<cv::Mat>& details, const cv::Mat& weight) {
  // Lags up to half the size each way: padding by half keeps them free of wrap-around.
  const cv::Size padded(cv::getOptimalDFTSize(weight.cols + weight.cols / 2 + 1),
                        cv::getOptimalDFTSize(weight.rows + weight.rows / 2 + 1));
  // Pixels overlapping at each lag: (w - |dx|)(h - |dy|) when every pixel
  // counts, else the weight's own autocorrelation.
  cv::Mat count;
  if (cv::countNonZero(weight != 1.0f) == 0) {
    count = cv::Mat::zeros(padded, CV_32F);
    for (int r = 0; r < padded.height; ++r) {
      const int dy = std::min(r, padded.height - r);
      for (int c = 0; c < padded.width; ++c) {
        const int dx = std::min(c, padded.width - c);
        count.at<float>(r, c) = static_cast<float>(std::max(0, weight.cols - dx)) *
                                static_cast<float>(std::max(0, weight.rows - dy));
      }
    }
  } else {
    count = autocorrelation(weight, padded);
  }
  const float min_count = 0.2f * count.at<float>(0, 0);
  const auto centred = [&](const cv::Mat& acf) {
    LagMap map;
    map.lx = weight.cols / 2;
    map.ly = weight.rows / 2;
    map.rho.create(2 * map.ly + 1, 2 * map.lx + 1, CV_32F);
    for (int dy = -map.ly; dy <= map.ly; ++dy) {
      const int r = (dy + padded.height) % padded.height;
      for (int dx = -map.lx; dx <= map.lx; ++dx) {
        const int c = (dx + padded.width) % padded.width;
        map.rho.at<float>(dy + map.ly, dx + map.lx) =
            count.at<float>(r, c) >= min_count ? acf.at<float>(r, c) : 0.0f;
      }
    }
    return map;
  };
  std::vector<LagMap> each;
  std::vector<double> strength;
  for (const auto& d : details) {
    cv::Mat acf = autocorrelation(d, padded);
    // Mean product over the overlap, over that at zero lag.
    cv::Mat mean = acf / cv::max(count, 1.0);
    mean /= std::max(1e-12f, mean.at<float>(0, 0));
    each.push_back(centred(mean));
    double top = 0;
    for (const Peak& peak : peaks_of(each.back()))
      top = std::max(top, peak.rho);
    strength.push_back(top * top);
  }
  double total = 0;
  for (const double w : strength)
    total += w;
  LagMap map;
  map.lx = each.front().lx;
  map.ly = each.front().ly;
  map.rho = cv::Mat(each.front().rho.size(), CV_32F, cv::Scalar(0));
  for (std::size_t i = 0; i < each.size(); ++i)
    // Nothing repeats by itself: the plain mean (a repeat may still show in it).
    map.rho += each[i].rho * (total > 0 ? strength[i] / total : 1.0 / each.size());
  return map;
}

// The peak near `guess` to a fraction of a pixel: the highest sample within
// `radius`, then a parabola through it and its neighbours along each axis.
std::optional<Peak> refine_peak(const LagMap& map, cv::Point2d guess, int radius) {
  const int gx = static_cast<int>(std::lround(guess.x));
  const int gy = static_cast<int>(std::lround(guess.y));
  if (!map.inside(gx, gy, radius + 2)) return std::nullopt;
  int bx = gx, by = gy;
  float best = -2;
  for (int dy = -radius; dy <= radius; ++dy)
    for (int dx = -radius; dx <= radius; ++dx)
      if (const float v = map.at(gx + dx, gy + dy); v > best) {
        best = v;
        bx = gx + dx;
        by = gy + dy;
      }
  if (std::abs(bx - gx) == radius || std::abs(by - gy) == radius) return std::nullopt;  // a slope
  const auto vertex = [](double m, double c, double p) {
    const double curvature = m - 2 * c + p;
    return curvature < 0 ? std::clamp(0.5 * (m - p) / curvature, -0.5, 0.5) : 0.0;
  };
  const double ox = vertex(map.at(bx - 1, by), best, map.at(bx + 1, by));
  const double oy = vertex(map.at(bx, by - 1), best, map.at(bx, by + 1));
  return Peak{{bx + ox, by + oy}, best};
}

// Lagrange-Gauss reduction: the shortest basis of the same lattice.
void reduce(cv::Point2d& a, cv::Point2d& b) {
  for (int i = 0; i < 32; ++i) {
    if (norm(b) < norm(a)) std::swap(a, b);
    const double mu = std::round(a.dot(b) / a.dot(a));
    if (mu == 0) break;
    b -= mu * a;
  }
}

// Least squares over every lattice point the lag map holds: the peaks far
// from zero pin the vectors down to a small fraction of a pixel.
void refine_lattice(const LagMap& map, cv::Point2d& a, cv::Point2d& b, double min_rho) {
  for (int pass = 0; pass < 3; ++pass) {
    const int radius = std::max(2, static_cast<int>(0.2 * std::min(norm(a), norm(b))));
    double g11 = 0, g12 = 0, g22 = 0;
    cv::Point2d r1, r2;
    int used = 0;
    for (int n = -40; n <= 40; ++n) {
      for (int m = -40; m <= 40; ++m) {
        const cv::Point2d guess = n * a + m * b;
        if (guess.y < 0 || (guess.y == 0 && guess.x <= 0) || (n == 0 && m == 0)) continue;
        const auto peak = refine_peak(map, guess, radius);
        if (!peak || peak->rho < min_rho) continue;
        g11 += n * n;
        g12 += n * m;
        g22 += m * m;
        r1 += n * peak->lag;
        r2 += m * peak->lag;
        ++used;
      }
    }
    const double det = g11 * g22 - g12 * g12;
    if (used < 2 || std::abs(det) < 1e-9) return;
    a = (g22 * r1 - g12 * r2) / det;
    b = (g11 * r2 - g12 * r1) / det;
  }
}

// Lattice vectors within the cone round `axis` (pointing along it), no
// longer than three times the shortest there.
std::vector<cv::Point2d> near_axis(cv::Point2d a, cv::Point2d b, cv::Point2d axis) {
  std::vector<cv::Point2d> inside;
  const double cone = std::cos(kAxisConeDeg / kDeg);
  double shortest = 0;
  for (int n = -8; n <= 8; ++n) {
    for (int m = -8; m <= 8; ++m) {
      const cv::Point2d w = n * a + m * b;
      const double length = norm(w);
      if (length < 1e-9 || w.dot(axis) < cone * length) continue;
      inside.push_back(w);
      if (shortest == 0 || length < shortest) shortest = length;
    }
  }
  std::erase_if(inside, [&](cv::Point2d w) { return norm(w) > 3 * shortest; });
  return inside;
}

// The fabric's two directions: of the lattice vectors near each image axis,
// the pair closest to square (then the smallest cell). A twill's (1 end,
// 3 picks) lies 14 degrees off the warp and is shorter than its (0, 4), but
// only (4, 0) and (0, 4) are square: the threads' own directions.
std::optional<std::pair<cv::Point2d, cv::Point2d>> fabric_axes(cv::Point2d a, cv::Point2d b) {
  const auto us = near_axis(a, b, {1, 0});
  const auto vs = near_axis(a, b, {0, 1});
  std::optional<std::pair<cv::Point2d, cv::Point2d>> best;
  double best_skew = 0, best_area = 0;
  for (const auto& u : us) {
    for (const auto& v : vs) {
      const double area = std::abs(cross(u, v));
      if (area < 1e-9) continue;
      const double skew = std::abs(u.dot(v)) / (norm(u) * norm(v));  // sine of the skew
      const double tolerance = std::sin(0.5 / kDeg);
      if (!best || skew < best_skew - tolerance ||
          (skew < best_skew + tolerance && area < best_area - 1e-6)) {
        best = std::pair{u, v};
        best_skew = skew;
        best_area = area;
      }
    }
  }
  return best;
}

// How many threads one repeat holds along `dir`: the maps' detail folded
// onto one repeat (each pixel binned by its phase along `dir`), then the
// lowest harmonic of the folded profile that carries half the strongest
// one's amplitude. Threads look alike on average, so a repeat of k threads
// folds to a profile with period 1/k. Two ways of putting the maps
// together:
// - `summed`: one profile of the maps' sum. Where a woven's height and
//   albedo fold to opposite phases (light warps, darker wefts on top of
//   the crossings) they cancel and it counts too few, so it is the cautious
//   cue for telling a woven by its threads: a knit's V, two mirror-image
//   legs a wale, can fold to a second harmonic in one map alone (the
//   height of a scan only a few stitches wide);
// - `count`: each map's amplitudes, summed: every map's threads, in
//   whatever phase. The count, once the cloth is known to be woven.
struct ThreadCount {
  int summed = 1;
  int count = 1;
};
ThreadCount threads_per_repeat(const std::vector<cv::Mat>& details, const cv::Mat& weight,
                               cv::Point2d u, cv::Point2d v, bool along_u) {
  const int bins = std::max(8, static_cast<int>(std::lround(norm(along_u ? u : v))));
  const double det = cross(u, v);
  const std::size_t maps = details.size();
  std::vector<double> sum(bins * maps, 0.0), count(bins, 0.0);
  for (int r = 0; r < weight.rows; ++r) {
    for (int c = 0; c < weight.cols; ++c) {
      const float w = weight.at<float>(r, c);
      if (w <= 0) continue;
      // Coordinates in repeats: (c, r) = s u + t v.
      const double s = (c * v.y - r * v.x) / det;
      const double t = (u.x * r - u.y * c) / det;
      const double phase = along_u ? s : t;
      const int bin = static_cast<int>((phase - std::floor(phase)) * bins) % bins;
      for (std::size_t m = 0; m < maps; ++m)
        sum[bin * maps + m] += details[m].at<float>(r, c);
      count[bin] += 1;
    }
  }
  std::vector<double> summed, each;
  const int harmonics = std::min(12, bins / 2 - 1);
  for (int k = 1; k <= harmonics; ++k) {
    std::complex<double> total;
    double amplitudes = 0;
    for (std::size_t m = 0; m < maps; ++m) {
      std::complex<double> c_k;
      for (int i = 0; i < bins; ++i) {
        if (count[i] == 0) continue;
        c_k +=
            (sum[i * maps + m] / count[i]) * std::polar(1.0, -2 * std::numbers::pi * k * i / bins);
      }
      total += c_k;
      amplitudes += std::abs(c_k);
    }
    summed.push_back(std::abs(total));
    each.push_back(amplitudes);
  }
  const auto lowest = [](const std::vector<double>& amplitude) {
    if (amplitude.empty()) return 1;
    const double top = *std::max_element(amplitude.begin(), amplitude.end());
    for (std::size_t k = 0; k < amplitude.size(); ++k)
      if (amplitude[k] >= 0.5 * top) return static_cast<int>(k) + 1;
    return 1;
  };
  return {lowest(summed), lowest(each)};
}

struct Prepared {
  std::vector<cv::Mat> details;
  cv::Mat weight;
};

Prepared prepare(const cv::Mat& height, const cv::Mat& albedo) {
  Prepared out;
  const cv::Rect centre = measured_region(height.size());
  cv::Mat hgt;
  height(centre).convertTo(hgt, CV_32F);
  cv::Mat wh;
  out.details.push_back(detail_of(hgt, wh));
  out.weight = wh;
  if (!albedo.empty() && albedo.size() == height.size()) {
    cv::Mat a = luminance(albedo(centre));
    a.setTo(std::numeric_limits<float>::quiet_NaN(), wh == 0);
    cv::Mat wa;
    cv::Mat detail = detail_of(a, wa);
    if (cv::countNonZero(detail) > 0) out.details.push_back(std::move(detail));
  }
  return out;
}

constexpr const char* kTooSmall = "the maps are too small to hold a repeat";
// Limits of what a repeat can be: two whole ones inside the maps each way.
constexpr const char* kTooLarge =
    "no repeat found: the repeat is larger than half the area measured (the central 1280 pixels a "
    "side)";
bool fits(const RepeatLattice& lattice, const cv::Mat& weight) {
  return norm(lattice.u_px) * 2 <= weight.cols && norm(lattice.v_px) * 2 <= weight.rows;
}

// Where the scan says one repeat holds `count` stitches (or threads) along
// a lattice vector, and that vector is only a sub-period: a partial match
// the 60 % rule took (a seed stitch's purl bump standing where the knit V
// beside it stands). A whole repeat, k times the vector for k dividing the
// count, then matches markedly better (by kWholeRepeatGain): the best such
// multiple is the repeat. A true repeat's multiples match no better.
cv::Point2d whole_repeat(const LagMap& map, cv::Point2d vector, int count) {
  const auto part = refine_peak(map, vector, 2);
  if (!part || count < 2) return vector;
  cv::Point2d best = vector;
  double best_rho = part->rho + kWholeRepeatGain;
  for (int k = 2; k <= count; ++k) {
    if (count % k != 0) continue;
    const auto whole = refine_peak(map, k * vector, 2);
    if (whole && whole->rho >= best_rho) {
      best = k * vector;
      best_rho = whole->rho;
    }
  }
  return best;
}

std::optional<RepeatLattice> lattice_of(const Prepared& in, const LagMap& map, std::string* why) {
  const auto say = [&](const std::string& text) {
    if (why) *why = text;
    return std::nullopt;
  };
  std::vector<Peak> peaks = peaks_of(map);
  double top = 0;
  for (const auto& p : peaks)
    top = std::max(top, p.rho);
  char text[200];
  if (top < kMinPeak) {
    std::snprintf(text, sizeof text,
                  "no repeat found: the autocorrelation's highest peak off zero is %.2f (a repeat "
                  "gives %.2f or more)",
                  top, kMinPeak);
    return say(text);
  }
  std::vector<Peak> strong;
  for (const auto& p : peaks)
    if (p.rho >= kCandidateFraction * top) strong.push_back(p);
  std::sort(strong.begin(), strong.end(),
            [](const Peak& x, const Peak& y) { return norm(x.lag) < norm(y.lag); });
  cv::Point2d a = strong.front().lag;
  std::optional<cv::Point2d> b;
  for (const auto& p : strong) {
    if (std::abs(cross(a, p.lag)) > std::sin(15.0 / kDeg) * norm(a) * norm(p.lag)) {
      b = p.lag;
      break;
    }
  }
  if (!b) return say("no repeat found: the texture repeats in one direction only (stripes)");
  reduce(a, *b);
  refine_lattice(map, a, *b, 0.3 * top);
  reduce(a, *b);
  const auto ra = refine_peak(map, a, 2);
  const auto rb = refine_peak(map, *b, 2);
  RepeatLattice lattice;
  lattice.a_px = a;
  lattice.b_px = *b;
  lattice.confidence = 0.5 * ((ra ? ra->rho : 0.0) + (rb ? rb->rho : 0.0));
  if (const auto axes = fabric_axes(a, *b)) {
    lattice.u_px = axes->first;
    lattice.v_px = axes->second;
  } else {
    // Far from the axes: the more horizontal basis vector is u.
    cv::Point2d x = a, y = *b;
    if (std::abs(x.x) / norm(x) < std::abs(y.x) / norm(y)) std::swap(x, y);
    if (x.x < 0) x = -x;
    if (y.y < 0) y = -y;
    lattice.u_px = x;
    lattice.v_px = y;
  }
  if (!fits(lattice, in.weight)) return say(kTooLarge);
  return lattice;
}

// Wales per repeat along u and courses per repeat along v for the knit
// structures older scans name without counting them (fabric.stitches_per_
// repeat): a 1x1 rib's repeat holds a knit and a purl wale, garter's a knit
// and a purl course.
std::optional<std::pair<int, int>> knit_stitches_per_repeat(const std::string& structure) {
  if (structure == "rib" || structure == "1x1 rib") return std::pair{2, 1};
  if (structure == "garter") return std::pair{1, 2};
  if (structure == "jersey") return std::pair{1, 1};
  return std::nullopt;
}

}  // namespace

std::string_view to_string(Construction construction) {
  switch (construction) {
    case Construction::knit:
      return "knit";
    case Construction::woven:
      return "woven";
    case Construction::unknown:
      break;
  }
  return "unknown";
}

Construction parse_construction(std::string_view name) {
  if (name == "knit" || name == "knitted") return Construction::knit;
  if (name == "woven") return Construction::woven;
  return Construction::unknown;
}

FabricHints fabric_hints(const nlohmann::json& doc) {
  FabricHints hints;
  if (!doc.is_object() || !doc.contains("fabric") || !doc["fabric"].is_object()) return hints;
  const auto& fabric = doc["fabric"];
  if (fabric.contains("construction") && fabric["construction"].is_string())
    hints.construction = parse_construction(fabric["construction"].get<std::string>());
  if (fabric.contains("structure") && fabric["structure"].is_string())
    hints.structure = fabric["structure"].get<std::string>();
  for (const char* key : {"stitches_per_repeat", "threads_per_repeat"}) {
    if (!fabric.contains(key)) continue;
    const auto& counts = fabric[key];
    const auto count = [&](std::size_t i) {
      return counts[i].is_number_integer() ? counts[i].get<std::int64_t>() : std::int64_t{0};
    };
    if (counts.is_array() && counts.size() == 2 && count(0) >= 1 && count(0) <= kMaxThreads &&
        count(1) >= 1 && count(1) <= kMaxThreads) {
      hints.across_per_repeat = static_cast<int>(count(0));
      hints.along_per_repeat = static_cast<int>(count(1));
    }
  }
  return hints;
}

std::optional<RepeatLattice> find_repeat_lattice(const cv::Mat& height, const cv::Mat& albedo,
                                                 std::string* why) {
  const Prepared prepared = prepare(height, albedo);
  if (prepared.weight.cols < 16 || prepared.weight.rows < 16) {
    if (why) *why = kTooSmall;
    return std::nullopt;
  }
  return lattice_of(prepared, lag_map(prepared.details, prepared.weight), why);
}

cv::Rect measured_region(cv::Size maps) {
  const int w = std::min(maps.width, kMaxWorkingSide);
  const int h = std::min(maps.height, kMaxWorkingSide);
  return {(maps.width - w) / 2, (maps.height - h) / 2, w, h};
}

Result<FabricMeasurement> measure_fabric(const cv::Mat& height, const cv::Mat& albedo,
                                         const MeasureOptions& options) {
  if (height.empty() || height.channels() != 1)
    return std::unexpected(bad_input({}, "height", "expected a one-channel height map"));
  FabricMeasurement m;
  m.pixel_size_mm = options.pixel_size_mm;
  m.structure = options.hints.structure;
  if (!options.pixel_size_mm)
    m.notes.push_back("no pixel_size_mm in the scan: densities are per pixel and sizes in pixels");
  const Prepared prepared = prepare(height, albedo);
  std::string why = kTooSmall;
  std::optional<LagMap> map;
  std::optional<RepeatLattice> lattice;
  if (prepared.weight.cols >= 16 && prepared.weight.rows >= 16) {
    map = lag_map(prepared.details, prepared.weight);
    lattice = lattice_of(prepared, *map, &why);
  }
  if (lattice) {
    // The scan's count of threads per repeat: a lattice vector that is a
    // sub-period of it is made whole (whole_repeat()).
    lattice->u_px = whole_repeat(*map, lattice->u_px, options.hints.across_per_repeat);
    lattice->v_px = whole_repeat(*map, lattice->v_px, options.hints.along_per_repeat);
    if (!fits(*lattice, prepared.weight)) {
      why = kTooLarge;
      lattice.reset();
    }
  }
  if (!lattice) {
    m.notes.push_back(why);
    m.construction = options.hints.construction;
    m.construction_from_metadata = m.construction != Construction::unknown;
    m.construction_confidence = m.construction_from_metadata ? 1.0 : 0.0;
    return m;
  }
  m.periodic = true;
  m.confidence = lattice->confidence;
  m.u_px = lattice->u_px;
  m.v_px = lattice->v_px;
  const double area = std::abs(cross(m.u_px, m.v_px));
  const double primitive = std::abs(cross(lattice->a_px, lattice->b_px));
  const int index = static_cast<int>(std::lround(area / std::max(primitive, 1e-9)));

  const cv::Point2d us = m.u_px, vs = m.v_px;
  const ThreadCount along_u = threads_per_repeat(prepared.details, prepared.weight, us, vs, true);
  const ThreadCount along_v = threads_per_repeat(prepared.details, prepared.weight, us, vs, false);
  const int threads_u = along_u.count, threads_v = along_v.count;

  if (options.hints.construction != Construction::unknown) {
    m.construction = options.hints.construction;
    m.construction_from_metadata = true;
    m.construction_confidence = 1.0;
  } else {
    // Weaves interlace thread by thread: their repeat along each direction
    // holds two or more alike threads, and a plain or twill cell is centred
    // or oblique (index 2 or more); a knit's loops stack on a plain
    // rectangular lattice.
    const int woven_cues =
        (index >= 2 ? 1 : 0) + (along_u.summed >= 2 && along_v.summed >= 2 ? 1 : 0);
    m.construction = woven_cues > 0 ? Construction::woven : Construction::knit;
    m.construction_confidence = woven_cues == 1 ? 0.6 : 0.8;
    m.notes.push_back(std::string("construction guessed from the structure (") +
                      (m.construction == Construction::woven ? "woven" : "knit") +
                      "); give scan.json's fabric.construction to be sure");
  }
  const bool counted = options.hints.across_per_repeat > 0 && options.hints.along_per_repeat > 0;
  if (counted) {
    // The pattern's own count, as the lab (or the simulator) gives it.
    m.threads_u = options.hints.across_per_repeat;
    m.threads_v = options.hints.along_per_repeat;
    if (m.construction == Construction::woven &&
        (threads_u != m.threads_u || threads_v != m.threads_v))
      m.notes.push_back("the scan's fabric says " + std::to_string(m.threads_u) + " x " +
                        std::to_string(m.threads_v) + " threads per repeat; the maps look like " +
                        std::to_string(threads_u) + " x " + std::to_string(threads_v));
  } else if (m.construction == Construction::woven) {
    m.threads_u = threads_u;
    m.threads_v = threads_v;
  } else {
    const auto named = knit_stitches_per_repeat(m.structure);
    m.threads_u = named ? named->first : 1;
    m.threads_v = named ? named->second : 1;
    if (!named)
      m.notes.push_back(
          "stitches per repeat not given: one wale and one course per repeat assumed (a 1x1 "
          "rib repeat holds two wales, garter two courses; give scan.json's "
          "fabric.stitches_per_repeat)");
  }
  const double unit = options.pixel_size_mm ? 10.0 / *options.pixel_size_mm : 1.0;  // px per cm
  m.across_density = m.threads_u * norm(m.v_px) / area * unit;
  m.along_density = m.threads_v * norm(m.u_px) / area * unit;
  m.rotation_deg = std::atan2(-m.u_px.y, m.u_px.x) * kDeg;
  m.wale_rotation_deg = std::atan2(m.v_px.x, m.v_px.y) * kDeg;
  m.skew_deg = m.wale_rotation_deg - m.rotation_deg;
  const double size = options.pixel_size_mm.value_or(1.0);
  m.repeat_width = norm(m.u_px) * size;
  m.repeat_height = area / norm(m.u_px) * size;
  return m;
}

nlohmann::json to_json(const FabricMeasurement& m) {
  nlohmann::json j;
  j["periodic"] = m.periodic;
  j["construction"] = to_string(m.construction);
  j["construction_source"] = m.construction_from_metadata ? "metadata" : "structure";
  j["construction_confidence"] = m.construction_confidence;
  if (!m.structure.empty()) j["structure"] = m.structure;
  const bool mm = m.pixel_size_mm.has_value();
  j["units"] = mm ? "per_cm" : "per_px";
  if (m.periodic) {
    j["confidence"] = m.confidence;
    const bool woven = m.construction == Construction::woven;
    const std::string per = mm ? "_per_cm" : "_per_px";
    j[(woven ? "ends" : "wales") + per] = m.across_density;
    j[(woven ? "picks" : "courses") + per] = m.along_density;
    j["skew_deg"] = m.skew_deg;
    j["rotation_deg"] = m.rotation_deg;
    j[woven ? "warp_rotation_deg" : "wale_rotation_deg"] = m.wale_rotation_deg;
    j[mm ? "repeat_mm" : "repeat_px"] = {m.repeat_width, m.repeat_height};
    j[woven ? "threads_per_repeat" : "stitches_per_repeat"] = {m.threads_u, m.threads_v};
    j["lattice_px"] = {{"u", {m.u_px.x, m.u_px.y}}, {"v", {m.v_px.x, m.v_px.y}}};
  }
  j["notes"] = m.notes;
  j["summary"] = summary_line(m);
  return j;
}

Result<FabricMeasurement> fabric_from_json(const nlohmann::json& j,
                                           std::optional<double> pixel_size_mm) {
  const auto missing = [](const std::string& key) {
    return std::unexpected(bad_input({}, "fabric." + key,
                                     "missing or malformed in report.json (reprocess the scan)"));
  };
  if (!j.is_object() || !j.contains("periodic") || !j["periodic"].is_boolean())
    return missing("periodic");
  FabricMeasurement m;
  m.pixel_size_mm = pixel_size_mm;
  m.periodic = j["periodic"].get<bool>();
  if (!j.contains("construction") || !j["construction"].is_string()) return missing("construction");
  m.construction = parse_construction(j["construction"].get<std::string>());
  m.construction_from_metadata = j.value("construction_source", "") == "metadata";
  m.construction_confidence = j.value("construction_confidence", 0.0);
  m.structure = j.value("structure", "");
  if (j.contains("notes") && j["notes"].is_array())
    for (const auto& note : j["notes"])
      if (note.is_string()) m.notes.push_back(note.get<std::string>());
  if (!m.periodic) return m;
  const auto point = [&](const char* key) -> std::optional<cv::Point2d> {
    const auto& lattice = j.contains("lattice_px") ? j["lattice_px"] : nlohmann::json();
    if (!lattice.is_object() || !lattice.contains(key) || !lattice[key].is_array() ||
        lattice[key].size() != 2 || !lattice[key][0].is_number() || !lattice[key][1].is_number())
      return std::nullopt;
    return cv::Point2d(lattice[key][0].get<double>(), lattice[key][1].get<double>());
  };
  const auto u = point("u"), v = point("v");
  if (!u) return missing("lattice_px.u");
  if (!v) return missing("lattice_px.v");
  m.u_px = *u;
  m.v_px = *v;
  const bool woven = m.construction == Construction::woven;
  const std::string per = pixel_size_mm ? "_per_cm" : "_per_px";
  const std::string across = (woven ? "ends" : "wales") + per;
  const std::string along = (woven ? "picks" : "courses") + per;
  if (!j.contains(across) || !j[across].is_number()) return missing(across);
  if (!j.contains(along) || !j[along].is_number()) return missing(along);
  m.across_density = j[across].get<double>();
  m.along_density = j[along].get<double>();
  m.confidence = j.value("confidence", 0.0);
  m.skew_deg = j.value("skew_deg", 0.0);
  m.rotation_deg = j.value("rotation_deg", 0.0);
  m.wale_rotation_deg = j.value(woven ? "warp_rotation_deg" : "wale_rotation_deg", 0.0);
  const auto& counts = j.value(woven ? "threads_per_repeat" : "stitches_per_repeat",
                               nlohmann::json::array({1, 1}));
  if (counts.is_array() && counts.size() == 2 && counts[0].is_number_integer() &&
      counts[1].is_number_integer()) {
    m.threads_u = counts[0].get<int>();
    m.threads_v = counts[1].get<int>();
  }
  const auto& repeat = j.value(pixel_size_mm ? "repeat_mm" : "repeat_px", nlohmann::json());
  if (repeat.is_array() && repeat.size() == 2 && repeat[0].is_number() && repeat[1].is_number()) {
    m.repeat_width = repeat[0].get<double>();
    m.repeat_height = repeat[1].get<double>();
  }
  return m;
}

std::string summary_line(const FabricMeasurement& m) {
  char text[400];
  const std::string what = (m.structure.empty() ? std::string() : m.structure + " ") +
                           std::string(to_string(m.construction)) +
                           (m.construction_from_metadata || m.construction == Construction::unknown
                                ? ""
                                : " (guessed from the structure)");
  if (!m.periodic) {
    std::snprintf(text, sizeof text, "%s: %s", what.c_str(),
                  m.notes.empty() ? "no repeat found" : m.notes.back().c_str());
    return text;
  }
  const bool woven = m.construction == Construction::woven;
  const bool mm = m.pixel_size_mm.has_value();
  const char* per = mm ? "cm" : "px";
  std::snprintf(
      text, sizeof text,
      "%s: %.*f %s/%s, %.*f %s/%s, skew %.2f deg, rotation %.2f deg, repeat %.3g x %.3g %s",
      what.c_str(), mm ? 2 : 4, m.across_density, woven ? "ends" : "wales", per, mm ? 2 : 4,
      m.along_density, woven ? "picks" : "courses", per, m.skew_deg, m.rotation_deg, m.repeat_width,
      m.repeat_height, mm ? "mm" : "px");
  return text;
}

}  // namespace psrig::analysis
