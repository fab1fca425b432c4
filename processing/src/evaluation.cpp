#include "psrig/processing/evaluation.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "psrig/base/parallel.h"
#include "psrig/base/vector_clones.h"
#include "psrig/processing/woodham.h"

namespace psrig::processing {
namespace {

constexpr int kStatisticsRowsPerChunk = 32;

// Sums per fixed row chunk, added up in chunk order: reproducible.
template <class Partial, class Body, class Combine>
Partial reduce_rows(int rows, Body body, Combine combine,
                    int chunk_rows = kStatisticsRowsPerChunk) {
  std::vector<Partial> partials(chunk_count(rows, chunk_rows));
  parallel_chunks(rows, chunk_rows,
                  [&](int begin, int end) { body(begin, end, partials[begin / chunk_rows]); });
  Partial total{};
  for (auto& partial : partials)
    combine(total, partial);
  return total;
}

// Floats to unsigned keys in the same order, so quantiles can be found by
// counting key prefixes instead of sorting.
std::uint32_t order_key(float value) {
  const auto bits = std::bit_cast<std::uint32_t>(value);
  return bits & 0x80000000u ? ~bits : bits | 0x80000000u;
}
float from_order_key(std::uint32_t key) {
  return std::bit_cast<float>(key & 0x80000000u ? key & 0x7FFFFFFFu : ~key);
}

bool selected_at(const std::uint8_t* select_row, int c) {
  return !select_row || select_row[c];
}

// The k-th smallest (0-based) selected finite values for each k in `ranks`
// (ascending): one histogram of the top 16 key bits finds each rank's
// bucket, a second pass sorts just those buckets' members.
std::vector<float> kth_smallest(const cv::Mat& values, const cv::Mat& select,
                                const std::vector<std::size_t>& ranks) {
  using Histogram = std::vector<std::size_t>;
  const Histogram histogram = reduce_rows<Histogram>(
      values.rows,
      [&](int begin, int end, Histogram& h) {
        h.assign(1 << 16, 0);
        for (int r = begin; r < end; ++r) {
          const float* v = values.ptr<float>(r);
          const std::uint8_t* s = select.empty() ? nullptr : select.ptr<std::uint8_t>(r);
          for (int c = 0; c < values.cols; ++c)
            if (selected_at(s, c) && std::isfinite(v[c])) ++h[order_key(v[c]) >> 16];
        }
      },
      [](Histogram& total, const Histogram& h) {
        if (total.empty()) total.assign(1 << 16, 0);
        for (std::size_t i = 0; i < h.size(); ++i)
          total[i] += h[i];
      },
      // Counts are exact in any order, so a few large chunks keep the
      // half-megabyte histograms few.
      std::max(1, values.rows / 8 + 1));

  std::vector<std::uint32_t> buckets;  // per rank
  std::vector<std::size_t> below;      // values in lower buckets, per rank
  std::uint32_t bucket = 0;
  std::size_t counted = 0;
  for (std::size_t k : ranks) {
    while (counted + histogram[bucket] <= k)
      counted += histogram[bucket++];
    buckets.push_back(bucket);
    below.push_back(counted);
  }
  // The buckets' members, gathered per chunk of rows on the pool: their
  // order does not matter to nth_element's answer.
  using Members = std::vector<std::vector<float>>;
  Members members = reduce_rows<Members>(
      values.rows,
      [&](int begin, int end, Members& found) {
        found.resize(ranks.size());
        for (int r = begin; r < end; ++r) {
          const float* v = values.ptr<float>(r);
          const std::uint8_t* s = select.empty() ? nullptr : select.ptr<std::uint8_t>(r);
          for (int c = 0; c < values.cols; ++c) {
            if (!selected_at(s, c) || !std::isfinite(v[c])) continue;
            const std::uint32_t key = order_key(v[c]) >> 16;
            for (std::size_t i = 0; i < ranks.size(); ++i)
              if (key == buckets[i]) found[i].push_back(v[c]);
          }
        }
      },
      [](Members& total, Members& found) {
        total.resize(found.size());
        for (std::size_t i = 0; i < found.size(); ++i)
          total[i].insert(total[i].end(), found[i].begin(), found[i].end());
        found.clear();
      },
      std::max(1, values.rows / 8 + 1));
  std::vector<float> result;
  for (std::size_t i = 0; i < ranks.size(); ++i) {
    const auto nth = members[i].begin() + static_cast<std::ptrdiff_t>(ranks[i] - below[i]);
    std::nth_element(members[i].begin(), nth, members[i].end());
    result.push_back(*nth);
  }
  return result;
}

}  // namespace

namespace {

// Count, sum, sum of squares and largest of the selected finite values of
// value(r, c) (values at row r, column c), per fixed chunk of rows.
struct Moments {
  std::size_t count = 0;
  double sum = 0, squares = 0;
  std::uint32_t largest = 0;
};
template <class Row>
Moments moments(int rows, int cols, const cv::Mat& select, Row row_of) {
  return reduce_rows<Moments>(
      rows,
      [&](int begin, int end, Moments& out) {
        std::vector<float> buffer(static_cast<std::size_t>(cols));
        for (int r = begin; r < end; ++r) {
          const float* v = row_of(r, buffer.data());
          const std::uint8_t* s = select.empty() ? nullptr : select.ptr<std::uint8_t>(r);
          for (int c = 0; c < cols; ++c) {
            if (!selected_at(s, c) || !std::isfinite(v[c])) continue;
            ++out.count;
            out.sum += v[c];
            out.squares += static_cast<double>(v[c]) * v[c];
            out.largest = std::max(out.largest, order_key(v[c]));
          }
        }
      },
      [](Moments& total, const Moments& s) {
        total.count += s.count;
        total.sum += s.sum;
        total.squares += s.squares;
        total.largest = std::max(total.largest, s.largest);
      });
}

Distribution of_moments(const Moments& sums) {
  Distribution d;
  d.count = sums.count;
  if (d.count == 0) return d;
  const auto n = static_cast<double>(d.count);
  d.mean = sums.sum / n;
  d.rms = std::sqrt(sums.squares / n);
  d.max = from_order_key(sums.largest);
  return d;
}

Moments moments_of(const cv::Mat& values, const cv::Mat& select) {
  return moments(values.rows, values.cols, select,
                 [&](int r, float*) { return values.ptr<float>(r); });
}

}  // namespace

Distribution describe_moments(const cv::Mat& values, const cv::Mat& select) {
  return of_moments(moments_of(values, select));
}

Distribution describe(const cv::Mat& values, const cv::Mat& select) {
  Distribution d = of_moments(moments_of(values, select));
  if (d.count == 0) return d;
  const auto n = static_cast<double>(d.count);
  const auto rank = [&](double fraction) {
    return static_cast<std::size_t>(std::llround(fraction * (n - 1)));
  };
  const auto quantiles = kth_smallest(values, select, {rank(0.5), rank(0.95)});
  d.median = quantiles[0];
  d.p95 = quantiles[1];
  return d;
}

PixelCounts count_pixels(const cv::Mat& flags) {
  return reduce_rows<PixelCounts>(
      flags.rows,
      [&](int begin, int end, PixelCounts& n) {
        for (int r = begin; r < end; ++r) {
          const std::uint8_t* f = flags.ptr<std::uint8_t>(r);
          for (int c = 0; c < flags.cols; ++c) {
            ++n.total;
            n.valid += is_valid(f[c]);
            n.outside_mask += (f[c] & kOutsideMask) != 0;
            n.saturated += (f[c] & kSaturated) != 0;
            n.shadowed += (f[c] & kShadowed) != 0;
            n.low_signal += (f[c] & kLowSignal) != 0;
            n.no_solution += (f[c] & kNoSolution) != 0;
            n.recovered += (f[c] & kRecovered) != 0;
            n.highlight += (f[c] & kHighlight) != 0;
          }
        }
      },
      [](PixelCounts& t, const PixelCounts& n) {
        t.total += n.total, t.valid += n.valid, t.outside_mask += n.outside_mask,
            t.saturated += n.saturated;
        t.shadowed += n.shadowed, t.low_signal += n.low_signal, t.no_solution += n.no_solution;
        t.recovered += n.recovered, t.highlight += n.highlight;
      });
}

namespace {

// atan(t) for 0 <= t, as glibc's atanf (fdlibm's) gives it, bit for bit, in
// a loop that vectorises: its argument reductions chosen per element by
// selects, then one division and its polynomial. (The file is compiled
// without contraction: an FMA would round otherwise. Checked against atanf
// over a hundred million arguments, and the 12 MP reports.)
PSRIG_VECTOR_CLONES
void atan_row(const float* __restrict t, float* __restrict out, int n) {
  for (int i = 0; i < n; ++i) {
    const float x = t[i];
    const bool small = x < 0.4375F;
    const bool r0 = !small && x < 0.6875F;
    const bool r1 = !small && !r0 && x < 1.1875F;
    const bool r2 = !small && !r0 && !r1 && x < 2.4375F;
    const float num = small ? x : r0 ? 2.0F * x - 1.0F : r1 ? x - 1.0F : r2 ? x - 1.5F : -1.0F;
    const float den = small ? 1.0F : r0 ? 2.0F + x : r1 ? x + 1.0F : r2 ? 1.0F + 1.5F * x : x;
    const float y = num / den;
    const float z = y * y;
    const float w = z * z;
    const float s1 =
        z * (3.3333334327e-01F +
             w * (1.4285714924e-01F +
                  w * (9.0908870101e-02F +
                       w * (6.6610731184e-02F + w * (4.9768779427e-02F + w * 1.6285819933e-02F)))));
    const float s2 =
        w * (-2.0000000298e-01F +
             w * (-1.1111110449e-01F +
                  w * (-7.6918758452e-02F + w * (-5.8335702866e-02F + w * -3.6531571299e-02F))));
    const float hi = r0   ? 4.6364760399e-01F
                     : r1 ? 7.8539812565e-01F
                     : r2 ? 9.8279368877e-01F
                          : 1.5707962513e+00F;
    const float lo = r0   ? 5.0121582440e-09F
                     : r1 ? 3.7748947079e-08F
                     : r2 ? 3.4473217170e-08F
                          : 7.5497894159e-08F;
    const float reduced = hi - ((y * (s1 + s2) - lo) - y);
    const float direct = y - y * (s1 + s2);
    out[i] = x >= 33554432.0F ? 1.5707962513e+00F + 7.5497894159e-08F : small ? direct : reduced;
  }
}

// |n x t| and n.t for one row, n = (-p, -q, 1) unnormalised, t the truth.
PSRIG_VECTOR_CLONES
void cross_and_dot(const float* __restrict p, const float* __restrict q, const float* __restrict t,
                   float* __restrict cross, float* __restrict dot, int n) {
  for (int c = 0; c < n; ++c) {
    const float nx = -p[c], ny = -q[c], nz = 1;
    const float tx = t[3 * c], ty = t[3 * c + 1], tz = t[3 * c + 2];
    const float cx = ny * tz - nz * ty, cy = nz * tx - nx * tz, cz = nx * ty - ny * tx;
    cross[c] = std::sqrt(cx * cx + cy * cy + cz * cz);
    dot[c] = nx * tx + ny * ty + nz * tz;
  }
}

// Where atan2(y, x) is atan(y / x) as glibc computes it: x positive and
// finite, y finite and at most 2^60 times x (glibc's own cut-off). Only on
// x86-64, whose glibc is built without FMA, is atan_row its atanf to the
// bit; elsewhere (aarch64's glibc contracts into FMAs) the library decides
// every case.
bool plain_quotient(float y, float x) {
#if defined(__x86_64__)
  const auto hy = static_cast<std::int32_t>(std::bit_cast<std::uint32_t>(y));
  const auto hx = static_cast<std::int32_t>(std::bit_cast<std::uint32_t>(x));
  return x > 0 && std::isfinite(x) && std::isfinite(y) && y >= 0 && ((hy - hx) >> 23) <= 60;
#else
  static_cast<void>(y), static_cast<void>(x);
  return false;
#endif
}

}  // namespace

cv::Mat angular_error_deg(const cv::Mat& p, const cv::Mat& q, const cv::Mat& truth) {
  cv::Mat error(p.size(), CV_32F);
  parallel_chunks(p.rows, kStatisticsRowsPerChunk, [&](int begin, int end) {
    std::vector<float> cross(static_cast<std::size_t>(p.cols));
    std::vector<float> dot(static_cast<std::size_t>(p.cols));
    std::vector<float> quotient(static_cast<std::size_t>(p.cols));
    for (int r = begin; r < end; ++r) {
      float* e = error.ptr<float>(r);
      // atan2 of |cross| and dot stays accurate for tiny angles, unlike acos.
      cross_and_dot(p.ptr<float>(r), q.ptr<float>(r), truth.ptr<float>(r), cross.data(), dot.data(),
                    p.cols);
      for (int c = 0; c < p.cols; ++c)
        quotient[static_cast<std::size_t>(c)] =
            plain_quotient(cross[static_cast<std::size_t>(c)], dot[static_cast<std::size_t>(c)])
                ? cross[static_cast<std::size_t>(c)] / dot[static_cast<std::size_t>(c)]
                : 0.0F;
      atan_row(quotient.data(), e, p.cols);
      for (int c = 0; c < p.cols; ++c) {
        const float y = cross[static_cast<std::size_t>(c)];
        const float x = dot[static_cast<std::size_t>(c)];
        const float angle = plain_quotient(y, x) ? e[c] : std::atan2(y, x);
        e[c] = angle * static_cast<float>(180 / std::numbers::pi);
      }
    }
  });
  return error;
}

double mean_abs_curl(const cv::Mat& p, const cv::Mat& q, const cv::Mat& select) {
  struct Sums {
    double sum = 0;
    std::size_t count = 0;
  };
  const Sums sums = reduce_rows<Sums>(
      p.rows,
      [&](int begin, int end, Sums& out) {
        for (int r = std::max(begin, 1); r < std::min(end, p.rows - 1); ++r) {
          const std::uint8_t* above = select.ptr<std::uint8_t>(r - 1);
          const std::uint8_t* here = select.ptr<std::uint8_t>(r);
          const std::uint8_t* below = select.ptr<std::uint8_t>(r + 1);
          const float* p_above = p.ptr<float>(r - 1);
          const float* p_below = p.ptr<float>(r + 1);
          const float* q_here = q.ptr<float>(r);
          for (int c = 1; c + 1 < p.cols; ++c) {
            if (!(here[c] && above[c] && below[c] && here[c - 1] && here[c + 1])) continue;
            // y grows toward the top, i.e. toward row r - 1.
            const double dp_dy = (p_above[c] - p_below[c]) / 2.0;
            const double dq_dx = (q_here[c + 1] - q_here[c - 1]) / 2.0;
            out.sum += std::abs(dp_dy - dq_dx);
            ++out.count;
          }
        }
      },
      [](Sums& total, const Sums& s) {
        total.sum += s.sum;
        total.count += s.count;
      });
  return sums.count ? sums.sum / static_cast<double>(sums.count) : 0;
}

double height_rms_error(const cv::Mat& height, const cv::Mat& truth, const cv::Mat& select) {
  // height - truth a row at a time, never held whole.
  const Distribution d =
      of_moments(moments(height.rows, height.cols, select, [&](int r, float* difference) {
        const float* h = height.ptr<float>(r);
        const float* t = truth.ptr<float>(r);
        for (int c = 0; c < height.cols; ++c)
          difference[c] = h[c] - t[c];
        return static_cast<const float*>(difference);
      }));
  // RMS about the mean: sqrt(E[d^2] - E[d]^2).
  return std::sqrt(std::max(0.0, d.rms * d.rms - d.mean * d.mean));
}

}  // namespace psrig::processing
