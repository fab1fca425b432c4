#include "psrig/analysis/colour_palette.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace psrig::analysis {
namespace {

// CIELAB's companding of XYZ / white.
float lab_f(float t) {
  constexpr float delta = 6.0f / 29.0f;
  return t > delta * delta * delta ? std::cbrt(t) : t / (3 * delta * delta) + 4.0f / 29.0f;
}

std::size_t nearest(const std::vector<Eigen::Vector3f>& centres, const Eigen::Vector3f& lab) {
  std::size_t best = 0;
  float best_d = std::numeric_limits<float>::max();
  for (std::size_t k = 0; k < centres.size(); ++k)
    if (const float d = (centres[k] - lab).squaredNorm(); d < best_d) {
      best_d = d;
      best = k;
    }
  return best;
}

// Lloyd's iterations: each colour to its nearest centre, each centre to
// its colours' mean (in CIELAB); a centre left without colours is dropped.
void lloyd(const std::vector<Eigen::Vector3f>& labs, std::vector<Eigen::Vector3f>& centres,
           std::vector<std::size_t>& label) {
  for (int iteration = 0; iteration < 10; ++iteration) {
    for (std::size_t i = 0; i < labs.size(); ++i)
      label[i] = nearest(centres, labs[i]);
    std::vector<Eigen::Vector3f> sum(centres.size(), Eigen::Vector3f::Zero());
    std::vector<int> count(centres.size(), 0);
    for (std::size_t i = 0; i < labs.size(); ++i) {
      sum[label[i]] += labs[i];
      ++count[label[i]];
    }
    std::vector<Eigen::Vector3f> next;
    for (std::size_t k = 0; k < centres.size(); ++k)
      if (count[k] > 0) next.push_back(sum[k] / static_cast<float>(count[k]));
    const bool settled = next.size() == centres.size() &&
                         std::equal(next.begin(), next.end(), centres.begin(),
                                    [](const auto& a, const auto& b) { return (a - b).norm() < 1e-3f; });
    centres = std::move(next);
    if (settled) break;
  }
  for (std::size_t i = 0; i < labs.size(); ++i)
    label[i] = nearest(centres, labs[i]);
}

}  // namespace

Eigen::Vector3f linear_rgb_to_lab(const Eigen::Vector3f& rgb) {
  // IEC 61966-2-1's matrix to XYZ, over the D65 white's XYZ.
  const Eigen::Vector3f c = rgb.cwiseMax(0.0f);
  const float x = (0.4124f * c.x() + 0.3576f * c.y() + 0.1805f * c.z()) / 0.95047f;
  const float y = 0.2126f * c.x() + 0.7152f * c.y() + 0.0722f * c.z();
  const float z = (0.0193f * c.x() + 0.1192f * c.y() + 0.9505f * c.z()) / 1.08883f;
  const float fx = lab_f(x), fy = lab_f(y), fz = lab_f(z);
  return {116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)};
}

float delta_e(const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  return (linear_rgb_to_lab(a) - linear_rgb_to_lab(b)).norm();
}

ColourPalette quantise_colours(std::span<const Eigen::Vector3f> linear_rgb, float merge_delta_e,
                               int max_colours, float min_share) {
  ColourPalette palette;
  if (linear_rgb.empty()) return palette;
  std::vector<Eigen::Vector3f> labs;
  labs.reserve(linear_rgb.size());
  for (const Eigen::Vector3f& c : linear_rgb)
    labs.push_back(linear_rgb_to_lab(c));

  // Leaders: a colour farther than merge_delta_e from every leader starts one.
  std::vector<Eigen::Vector3f> centres;
  for (const Eigen::Vector3f& lab : labs)
    if (centres.empty() || (centres[nearest(centres, lab)] - lab).norm() > merge_delta_e)
      centres.push_back(lab);
  std::vector<std::size_t> label(labs.size(), 0);
  lloyd(labs, centres, label);

  // Rare entries (stray stitches, seams) and any past max_colours join the rest.
  const auto counts = [&] {
    std::vector<int> count(centres.size(), 0);
    for (const std::size_t l : label)
      ++count[l];
    return count;
  };
  for (;;) {
    const std::vector<int> count = counts();
    const auto fewest = static_cast<std::size_t>(
        std::min_element(count.begin(), count.end()) - count.begin());
    const bool rare = static_cast<float>(count[fewest]) <
                      min_share * static_cast<float>(labs.size());
    if (centres.size() <= 1 || (!rare && static_cast<int>(centres.size()) <= max_colours)) break;
    centres.erase(centres.begin() + static_cast<std::ptrdiff_t>(fewest));
    lloyd(labs, centres, label);
  }

  // Most used first; each entry the mean of its colours in linear RGB.
  const std::vector<int> count = counts();
  std::vector<std::size_t> order(centres.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return count[a] > count[b]; });
  std::vector<std::uint8_t> rank(centres.size());
  for (std::size_t r = 0; r < order.size(); ++r)
    rank[order[r]] = static_cast<std::uint8_t>(r);
  palette.colours.assign(centres.size(), Eigen::Vector3f::Zero());
  palette.index.resize(labs.size());
  for (std::size_t i = 0; i < labs.size(); ++i) {
    palette.index[i] = rank[label[i]];
    palette.colours[rank[label[i]]] += linear_rgb[i];
  }
  for (std::size_t k = 0; k < centres.size(); ++k)
    palette.colours[rank[k]] /= static_cast<float>(count[k]);
  return palette;
}

}  // namespace psrig::analysis
