#include "psrig/preview/yarn_slice.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

namespace psrig::preview {
namespace {

constexpr float kTwoPi = 2 * std::numbers::pi_v<float>;
// The light channel holds light / kLightRange (striation brightens too).
constexpr float kLightRange = 1.25f;

struct Texel {
  float ply = 0, tilt = 0, light = 1, density = 0;
};

std::array<std::uint8_t, 4> encode(const Texel& texel) {
  const auto byte = [](float value) {
    return static_cast<std::uint8_t>(std::lround(std::clamp(value, 0.0f, 1.0f) * 255.0f));
  };
  const float a = std::clamp(texel.density, 0.0f, 1.0f);
  return {byte(0.5f + 0.5f * std::clamp(texel.ply, -1.0f, 1.0f) * a),
          byte(0.5f + 0.5f * std::clamp(texel.tilt, -1.0f, 1.0f) * a),
          byte(std::clamp(texel.light, 0.0f, kLightRange) / kLightRange * a), byte(a)};
}

std::uint32_t hash(std::uint32_t x) {  // Wellons' lowbias32
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

float signed_noise(std::uint32_t lattice) {
  return static_cast<float>(hash(lattice) >> 8) / 16777215.0f * 2 - 1;
}

// Value noise on a periodic 1D lattice (`period` cells), smoothly interpolated.
float striation_noise(float coordinate, int period, std::uint32_t salt) {
  const float cell = std::floor(coordinate);
  const int below = ((static_cast<int>(cell) % period) + period) % period;
  const float a = signed_noise(salt * 7919U + static_cast<std::uint32_t>(below));
  const float b = signed_noise(salt * 7919U + static_cast<std::uint32_t>((below + 1) % period));
  const float t = coordinate - cell;
  return a + (b - a) * t * t * (3 - 2 * t);
}

// The plies as seen along the cloth's normal at one point of the slice:
// the front-most ply surface over `across` (yarn radii) at `along_mm`.
struct PlyHit {
  bool hit = false;
  float depth = 0;   // toward the eye, yarn radii
  float offset = 0;  // across the ply, -1 to 1
  int ply = 0;
  float slant = 0;  // dx/dz of the ply's axis there, mm per mm
};

struct PlyGeometry {
  int plies = 1;
  float ply_radius = 1, centre_radius = 0;  // yarn radii
  float flatness = 1;
  float radius_mm = 1;
  float pitch_mm = 0;  // 0: untwisted

  [[nodiscard]] PlyHit front(float across, float along_mm) const {
    PlyHit best;
    const float turn = pitch_mm > 0 ? kTwoPi * along_mm / pitch_mm : 0;
    for (int k = 0; k < plies; ++k) {
      const float angle = turn + kTwoPi * static_cast<float>(k) / static_cast<float>(plies);
      const float cx = centre_radius * std::cos(angle);
      const float cy = flatness * centre_radius * std::sin(angle);
      const float q = (across - cx) / ply_radius;
      if (std::abs(q) >= 1) continue;
      const float depth = cy + flatness * ply_radius * std::sqrt(1 - q * q);
      if (!best.hit || depth > best.depth) {
        best = {true, depth, q, k, 0};
        // d(cx)/dz in mm per mm: the ply's axis leaning as it winds round.
        best.slant = pitch_mm > 0
                         ? -centre_radius * radius_mm * std::sin(angle) * kTwoPi / pitch_mm
                         : 0;
      }
    }
    return best;
  }
};

// Alpha-weighted 2x2 average (chen2003 eq. 11 on the encoded, already
// premultiplied values: a plain average of each channel).
YarnSliceLevel halve(const YarnSliceLevel& level) {
  YarnSliceLevel next;
  next.width = std::max(level.width / 2, 1);
  next.height = std::max(level.height / 2, 1);
  next.texels.resize(static_cast<std::size_t>(next.width * next.height));
  for (int j = 0; j < next.height; ++j)
    for (int i = 0; i < next.width; ++i) {
      std::array<int, 4> sum{};
      int count = 0;
      for (int dj = 0; dj < 2; ++dj)
        for (int di = 0; di < 2; ++di) {
          const int x = std::min(2 * i + di, level.width - 1);
          const int y = std::min(2 * j + dj, level.height - 1);
          const auto& texel = level.texels[static_cast<std::size_t>(y * level.width + x)];
          for (int c = 0; c < 4; ++c)
            sum[c] += texel[c];
          ++count;
        }
      auto& out = next.texels[static_cast<std::size_t>(j * next.width + i)];
      for (int c = 0; c < 4; ++c)
        out[c] = static_cast<std::uint8_t>((sum[c] + count / 2) / count);
    }
  return next;
}

// The plies' layout across the section: `plies` round tubes touching
// their neighbours about the axis (one filling the section when single).
PlyGeometry ply_geometry(const cloth::YarnStyle& style, float radius, float pitch) {
  PlyGeometry plies;
  plies.plies = std::max(style.plies, 1);
  plies.flatness = std::clamp(style.flatness, 0.1f, 1.0f);
  plies.radius_mm = radius;
  plies.pitch_mm = pitch;
  if (plies.plies > 1) {
    const float s = std::sin(std::numbers::pi_v<float> / static_cast<float>(plies.plies));
    plies.ply_radius = s / (1 + s);
    plies.centre_radius = 1 - plies.ply_radius;
  }
  return plies;
}

// The slice's texels: `width` across the strip (`extent` yarn radii either
// side), `height` along the period.
struct SliceGrid {
  int width = 4, height = 4;
  float extent = 1;  // across, yarn radii either side
  float period_mm = 1;

  [[nodiscard]] float across_of(float i) const { return ((i + 0.5f) / width * 2 - 1) * extent; }
  [[nodiscard]] float along_of(float j) const { return (j + 0.5f) / height * period_mm; }
  [[nodiscard]] std::size_t size() const { return static_cast<std::size_t>(width * height); }
};

// The core: the plies, the grooves between them, the fibres' stripes.
// Light reaching a point falls with how far it lies below the ply crests
// either side of it (a groove has higher neighbours on both sides; a
// crest or the yarn's silhouette has none on one).
void shade_core(const SliceGrid& grid, const PlyGeometry& plies, float fibre_twist,
                const YarnSliceOptions& options, std::vector<Texel>& texels) {
  const int width = grid.width, height = grid.height;
  const float pitch = plies.pitch_mm;
  const int stripes = std::max(options.fibres_per_ply, 1);
  const int neighbourhood =
      std::max(1, static_cast<int>(std::lround(plies.ply_radius / (2 * grid.extent) *
                                               static_cast<float>(width))));
  std::vector<PlyHit> row(static_cast<std::size_t>(width));
  std::vector<float> crest(static_cast<std::size_t>(width));
  for (int j = 0; j < height; ++j) {
    const float z = grid.along_of(static_cast<float>(j));
    for (int i = 0; i < width; ++i) {
      const float x = grid.across_of(static_cast<float>(i));
      row[i] = std::abs(x) <= 1 ? plies.front(x, z) : PlyHit{};
      crest[i] = row[i].hit ? row[i].depth : -std::numeric_limits<float>::infinity();
    }
    for (int i = 0; i < width; ++i) {
      const float x = grid.across_of(static_cast<float>(i));
      if (std::abs(x) > 1) continue;
      Texel& texel = texels[static_cast<std::size_t>(j * width + i)];
      texel.density = 1;
      const PlyHit& hit = row[i];
      if (!hit.hit) {  // between plies seen edge on: the groove's bottom
        texel.light = std::exp(-options.groove_shadow);
        continue;
      }
      float left = -std::numeric_limits<float>::infinity(), right = left;
      for (int k = 1; k <= neighbourhood; ++k) {
        if (i - k >= 0) left = std::max(left, crest[i - k]);
        if (i + k < width) right = std::max(right, crest[i + k]);
      }
      const float below =
          std::max(std::min(left, right) - hit.depth, 0.0f) / (plies.flatness * plies.ply_radius);
      const float tilt =
          plies.plies > 1 ? (1 - options.balance) * std::atan(hit.slant) : fibre_twist;
      texel.tilt = std::sin(tilt);
      texel.ply = plies.plies > 1 ? hit.offset : 0;
      // Stripes follow the fibres round the ply, a whole number per period.
      const float round_ply = std::asin(std::clamp(hit.offset, -1.0f, 1.0f)) / kTwoPi;
      const float stripe =
          static_cast<float>(stripes) * (round_ply - (pitch > 0 ? z / pitch : 0.0f));
      const float noise =
          striation_noise(stripe, stripes, static_cast<std::uint32_t>(hit.ply) + options.seed);
      texel.light = std::exp(-options.groove_shadow * below) * (1 + options.striation * noise);
    }
  }
}

// The flyaway fibres' coverage of each texel, and their tilt summed
// weighted by it.
struct FlyawayCoverage {
  std::vector<float> coverage, tilt_sum;
};

// One segment of a fibre, `segment` mm long leaning `dx` across, at texel
// coordinates (fi, fj): its coverage splatted bilinearly, one segment's
// worth of fibre length (`share` of a texel), wrapped round the period.
void splat_segment(const SliceGrid& grid, float fi, float fj, float share, float segment, float dx,
                   FlyawayCoverage& fibres) {
  const int width = grid.width, height = grid.height;
  const int i0 = static_cast<int>(std::floor(fi)), j0 = static_cast<int>(std::floor(fj));
  for (int dj = 0; dj < 2; ++dj)
    for (int di = 0; di < 2; ++di) {
      const int i = i0 + di;
      if (i < 0 || i >= width) continue;
      const int j = (((j0 + dj) % height) + height) % height;
      const float w = (di ? fi - static_cast<float>(i0) : 1 - (fi - static_cast<float>(i0))) *
                      (dj ? fj - static_cast<float>(j0) : 1 - (fj - static_cast<float>(j0)));
      const auto index = static_cast<std::size_t>(j * width + i);
      const float add = std::min(w * share, 1.0f);
      fibres.coverage[index] = 1 - (1 - fibres.coverage[index]) * (1 - add);
      fibres.tilt_sum[index] += add * (segment > 0 ? dx / segment : 0);
    }
}

// Flyaways (huang2025 eq. 12, 13): R(t) = R0 + Re (1 - (1 - t)^alpha),
// theta(t) = theta0 + theta_e t, z(t) = z0 + z_e t, wrapped round the
// period; kept where they pass in front of the core or outside it.
FlyawayCoverage trace_flyaways(const SliceGrid& grid, const PlyGeometry& plies, float hairiness,
                               const YarnSliceOptions& options) {
  FlyawayCoverage fibres{std::vector<float>(grid.size(), 0.0f),
                         std::vector<float>(grid.size(), 0.0f)};
  const float radius = plies.radius_mm, extent = grid.extent;
  std::mt19937 random(options.seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  const int flyaways = static_cast<int>(
      std::lround(options.flyaways_per_mm * std::max(hairiness, 0.0f) * grid.period_mm));
  const float texel_across = 2 * extent / static_cast<float>(grid.width);      // yarn radii
  const float texel_along = grid.period_mm / static_cast<float>(grid.height);  // mm
  const float width_texels = std::min(options.fibre_diameter / texel_across, 1.0f);
  for (int f = 0; f < flyaways; ++f) {
    const float z0 = unit(random) * grid.period_mm;
    const float theta0 = unit(random) * kTwoPi;
    const float start = 0.85f;
    const float reach = options.halo * (0.25f + 0.85f * unit(random));
    const float theta_e = (unit(random) * 2 - 1) * 0.9f;
    const float length = radius * (1.5f + 3 * unit(random)) * (unit(random) < 0.5f ? -1.0f : 1.0f);
    const float alpha = 1 + 2 * unit(random);
    float previous_x = 0, previous_z = 0;
    constexpr int kSteps = 96;
    for (int s = 0; s <= kSteps; ++s) {
      const float t = static_cast<float>(s) / kSteps;
      const float r = start + reach * (1 - std::pow(1 - t, alpha));
      const float theta = theta0 + theta_e * t;
      const float x = r * std::cos(theta);
      const float depth = plies.flatness * r * std::sin(theta);
      const float z = z0 + length * t;
      const float dx = (x - previous_x) * radius, dz = z - previous_z;
      previous_x = x;
      previous_z = z;
      if (s == 0) continue;
      const float front = plies.flatness * std::sqrt(std::max(1 - x * x, 0.0f));
      if (std::abs(x) < 1 && depth < front) continue;  // behind the core
      if (std::abs(x) >= extent) continue;
      const float segment = std::hypot(dx, dz);
      const float fi = ((x / extent + 1) / 2) * static_cast<float>(grid.width) - 0.5f;
      const float fj = z / texel_along - 0.5f;
      const float share = width_texels * std::min(segment / texel_along, 1.5f);
      splat_segment(grid, fi, fj, share, segment, dx, fibres);
    }
  }
  return fibres;
}

// The flyaways over the core where they cross it, the halo beside it.
void draw_flyaways(const FlyawayCoverage& fibres, std::vector<Texel>& texels) {
  for (std::size_t index = 0; index < texels.size(); ++index) {
    const float c = std::min(fibres.coverage[index], 1.0f);
    if (c <= 0) continue;
    Texel& texel = texels[index];
    const float fly_tilt = std::clamp(fibres.tilt_sum[index] / std::max(c, 1e-3f), -1.0f, 1.0f);
    if (texel.density >= 1) {  // over the core: seen in front of it
      texel.ply *= 1 - c;
      texel.tilt += (fly_tilt - texel.tilt) * c;
      texel.light += (1 - texel.light) * c;
    } else {
      texel = {0, fly_tilt, 1, c};
    }
  }
}

// The core's mean, as the coarsest mipmap would give it without the halo
// (the default sample when no texel is core).
SliceSample core_mean(const std::vector<Texel>& texels) {
  double sums[4] = {};
  for (std::size_t index = 0; index < texels.size(); ++index) {
    const Texel& texel = texels[index];
    if (texel.density < 1) continue;
    sums[0] += texel.ply;
    sums[1] += texel.tilt;
    sums[2] += texel.light;
    sums[3] += 1;
  }
  if (sums[3] <= 0) return {};
  return {static_cast<float>(sums[0] / sums[3]), static_cast<float>(sums[1] / sums[3]),
          static_cast<float>(sums[2] / sums[3]), 1};
}

// The texels encoded as level 0, then halved down to 1x1.
std::vector<YarnSliceLevel> mipmaps(const SliceGrid& grid, const std::vector<Texel>& texels) {
  std::vector<YarnSliceLevel> levels;
  YarnSliceLevel level{grid.width, grid.height, {}};
  level.texels.reserve(texels.size());
  for (const Texel& texel : texels)
    level.texels.push_back(encode(texel));
  levels.push_back(std::move(level));
  while (levels.back().width > 1 || levels.back().height > 1)
    levels.push_back(halve(levels.back()));
  return levels;
}

}  // namespace

bool same_slice(const cloth::YarnStyle& a, const cloth::YarnStyle& b) {
  return a.radius_mm == b.radius_mm && a.flatness == b.flatness && a.plies == b.plies &&
         a.twist_pitch_mm == b.twist_pitch_mm && a.hairiness == b.hairiness;
}

YarnSlice bake_yarn_slice(const cloth::YarnStyle& style, const YarnSliceOptions& options) {
  YarnSlice slice;
  slice.style = style;
  slice.halo = options.halo;
  const float radius = std::max(style.radius_mm, 1e-3f);
  const float pitch = style.twist_pitch_mm > 0 ? style.twist_pitch_mm : 0;
  slice.period_mm =
      static_cast<float>(std::max(options.turns, 1)) * (pitch > 0 ? pitch : 4 * radius);

  const PlyGeometry plies = ply_geometry(style, radius, pitch);
  slice.ply_repeats = pitch > 0 ? std::max(options.turns, 1) * plies.plies : 1;
  // The fibres on a ply's face wind about the ply's axis against its lean.
  const float ply_radius_mm = plies.ply_radius * radius;
  const float fibre_twist =
      pitch > 0 ? std::atan(kTwoPi * (plies.plies > 1 ? ply_radius_mm : radius) / pitch) : 0;
  slice.ply_slant_sin =
      pitch > 0 ? std::sin(std::atan(-plies.centre_radius * radius * kTwoPi / pitch)) : 0;

  const SliceGrid grid{std::max(options.width, 4), std::max(options.height, 4), 1 + options.halo,
                       slice.period_mm};
  std::vector<Texel> texels(grid.size());
  shade_core(grid, plies, fibre_twist, options, texels);
  draw_flyaways(trace_flyaways(grid, plies, style.hairiness, options), texels);
  slice.core_mean = core_mean(texels);
  slice.levels = mipmaps(grid, texels);
  return slice;
}

float slice_u(const YarnSlice& slice, float across) {
  return 0.5f + 0.5f * across / (1 + slice.halo);
}

float slice_v(const YarnSlice& slice, float arc_mm) {
  return arc_mm / slice.period_mm;
}

SliceSample decode_texel(const std::array<std::uint8_t, 4>& texel) {
  const float density = texel[3] / 255.0f;
  const float inverse = 1 / std::max(density, 1 / 255.0f);
  return {(texel[0] / 255.0f * 2 - 1) * inverse, (texel[1] / 255.0f * 2 - 1) * inverse,
          texel[2] / 255.0f * kLightRange * inverse, density};
}

SliceSample sample_slice(const YarnSlice& slice, int level_index, float u, float v) {
  const YarnSliceLevel& level =
      slice.levels[static_cast<std::size_t>(std::clamp(level_index, 0, int(slice.levels.size()) - 1))];
  const float x = u * static_cast<float>(level.width) - 0.5f;
  const float y = (v - std::floor(v)) * static_cast<float>(level.height) - 0.5f;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const float fx = x - static_cast<float>(x0), fy = y - static_cast<float>(y0);
  std::array<float, 4> filtered{};
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const int i = std::clamp(x0 + dx, 0, level.width - 1);
      const int j = (((y0 + dy) % level.height) + level.height) % level.height;
      const float w = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy);
      const auto& texel = level.texels[static_cast<std::size_t>(j * level.width + i)];
      for (int c = 0; c < 4; ++c)
        filtered[c] += w * texel[c] / 255.0f;
    }
  const float density = filtered[3];
  const float inverse = 1 / std::max(density, 1 / 255.0f);
  return {(filtered[0] * 2 - 1) * inverse, (filtered[1] * 2 - 1) * inverse,
          filtered[2] * kLightRange * inverse, density};
}

}  // namespace psrig::preview
