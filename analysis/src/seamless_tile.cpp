#include "psrig/analysis/seamless_tile.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "plane_vectors.h"
#include "psrig/formats/atomic_directory.h"
#include "psrig/formats/image_io.h"
#include "psrig/formats/map_encoding.h"
#include "psrig/formats/scan_layout.h"

namespace psrig::analysis {

namespace fs = std::filesystem;

namespace {

// Where the tile lies in the scan: tile pixel (i, j) samples the scan at
// origin + (i + 0.5) / width * nu * u + (j + 0.5) / height * nv * v, for i
// and j from -band (the continuation before the tile, which the cross-fade
// blends into its far edges) up to width and height.
struct Frame {
  cv::Point2d origin, u, v;
  int nu = 1, nv = 1;
  int width = 0, height = 0;
  int band = 0;
};

bool fits(const Frame& f, cv::Size scan) {
  const double bs = static_cast<double>(f.band) / f.width * f.nu;  // band in repeats
  const double bt = static_cast<double>(f.band) / f.height * f.nv;
  for (const double s : {-bs, static_cast<double>(f.nu)}) {
    for (const double t : {-bt, static_cast<double>(f.nv)}) {
      const cv::Point2d p = f.origin + s * f.u + t * f.v;
      // Bicubic sampling reads one pixel beyond.
      if (p.x < 1 || p.y < 1 || p.x > scan.width - 2 || p.y > scan.height - 2) return false;
    }
  }
  return true;
}

// The frame holding nu x nv repeats, centred in the scan.
Frame periodic_frame(cv::Point2d u, cv::Point2d v, int nu, int nv, cv::Size scan) {
  Frame f;
  f.u = u;
  f.v = v;
  f.nu = nu;
  f.nv = nv;
  const double course_spacing = std::abs(cross(u, v)) / norm(u);
  // Deskewed: u along the tile's x, the course lines' spacing along its y;
  // the pixel size stays the scan's.
  f.width = static_cast<int>(std::lround(nu * norm(u)));
  f.height = static_cast<int>(std::lround(nv * course_spacing));
  // Half a repeat: wide enough to hide the join, narrow enough to keep most
  // of the tile untouched.
  f.band = std::max(4, static_cast<int>(std::lround(0.5 * std::min(norm(u), course_spacing))));
  const double bs = static_cast<double>(f.band) / f.width * nu;
  const double bt = static_cast<double>(f.band) / f.height * nv;
  const cv::Point2d centre(0.5 * (scan.width - 1), 0.5 * (scan.height - 1));
  f.origin = centre - 0.5 * ((nu - bs) * u + (nv - bt) * v);
  return f;
}

// The whole scan: the first `band` rows and columns are the continuation
// blended into the far edges.
Frame whole_scan_frame(cv::Size scan) {
  Frame f;
  f.band = std::clamp(std::min(scan.width, scan.height) / 16, 4, 64);
  f.width = scan.width - f.band;
  f.height = scan.height - f.band;
  f.u = {static_cast<double>(f.width), 0};
  f.v = {0, static_cast<double>(f.height)};
  f.origin = {f.band - 0.5, f.band - 0.5};
  return f;
}

void sampling_maps(const Frame& f, cv::Mat& mx, cv::Mat& my) {
  mx.create(f.height + f.band, f.width + f.band, CV_32F);
  my.create(mx.size(), CV_32F);
  for (int row = 0; row < mx.rows; ++row) {
    const double t = (row - f.band + 0.5) / f.height * f.nv;
    auto* x = mx.ptr<float>(row);
    auto* y = my.ptr<float>(row);
    for (int col = 0; col < mx.cols; ++col) {
      const double s = (col - f.band + 0.5) / f.width * f.nu;
      const cv::Point2d p = f.origin + s * f.u + t * f.v;
      x[col] = static_cast<float>(p.x);
      y[col] = static_cast<float>(p.y);
    }
  }
}

// The cross-fade: across the last `band` columns the tile turns, along a
// raised cosine, into the continuation that lies just before its first
// column (one whole tile of repeats away, so the same texture in phase);
// its last column then meets its first as two neighbours in the scan do.
// Then the same for the rows.
cv::Mat cross_fade(const cv::Mat& e, int width, int height, int band) {
  const int cn = e.channels();
  // k from 0 to band - 1: 0 at the first, exactly 1 at the last two, so
  // that the last columns are the continuation itself and the join's second
  // difference is the scan's own, even where the two sides do not match.
  const auto weight = [band](int k) {
    const float t = std::clamp(static_cast<float>(k) / static_cast<float>(band - 2), 0.0f, 1.0f);
    return 0.5f - 0.5f * std::cos(static_cast<float>(std::numbers::pi) * t);
  };
  cv::Mat x(height + band, width, e.type());
  for (int r = 0; r < x.rows; ++r) {
    const auto* src = e.ptr<float>(r);
    auto* dst = x.ptr<float>(r);
    for (int i = 0; i < width; ++i) {
      const int k = i - (width - band);
      const float w = k >= 0 ? weight(k) : 0.0f;
      for (int c = 0; c < cn; ++c) {
        const float a = src[(i + band) * cn + c];
        dst[i * cn + c] = k >= 0 ? (1 - w) * a + w * src[(i + band - width) * cn + c] : a;
      }
    }
  }
  cv::Mat out(height, width, e.type());
  for (int j = 0; j < height; ++j) {
    const int k = j - (height - band);
    const float w = k >= 0 ? weight(k) : 0.0f;
    const auto* a = x.ptr<float>(j + band);
    const auto* b = k >= 0 ? x.ptr<float>(j + band - height) : a;
    auto* dst = out.ptr<float>(j);
    for (int i = 0; i < width * cn; ++i)
      dst[i] = (1 - w) * a[i] + w * b[i];
  }
  return out;
}

// RMS over the finite values of the second difference across line `k`:
// columns when `columns`, else rows.
double line_rms(const cv::Mat& m, int k, bool columns, long* finite = nullptr) {
  double sum = 0;
  long count = 0;
  const int n = columns ? m.rows : m.cols;
  for (int l = 0; l < n; ++l) {
    float before, at, after;
    if (columns) {
      const auto* row = m.ptr<float>(l);
      before = row[k - 1];
      at = row[k];
      after = row[k + 1];
    } else {
      before = m.at<float>(k - 1, l);
      at = m.at<float>(k, l);
      after = m.at<float>(k + 1, l);
    }
    const float d = after - 2 * at + before;
    if (std::isfinite(d)) {
      sum += static_cast<double>(d) * d;
      ++count;
    }
  }
  if (finite) *finite += count;
  return count ? std::sqrt(sum / static_cast<double>(count)) : 0.0;
}

// Where in the repeat the seam should fall: the phase (tile pixels from
// the start of a repeat) whose lines have the smallest second difference,
// so that the join lies where the fabric is smoothest (between threads,
// not across a yarn's edge).
int smoothest_phase(const cv::Mat& map, int repeats, bool columns) {
  const int lines = columns ? map.cols : map.rows;
  const double period = static_cast<double>(lines) / repeats;
  const int bins = std::max(1, static_cast<int>(period));
  std::vector<double> sum(bins, 0.0), count(bins, 0.0);
  for (int k = 1; k < lines - 1; ++k) {
    const int bin = static_cast<int>(std::fmod(k, period)) % bins;
    sum[bin] += line_rms(map, k, columns);
    count[bin] += 1;
  }
  int best = 0;
  for (int b = 1; b < bins; ++b)
    if (count[b] > 0 && sum[b] / count[b] < sum[best] / std::max(1.0, count[best])) best = b;
  return best;
}

cv::Mat grey_of(const cv::Mat& bgr) {
  cv::Mat grey;
  cv::transform(bgr, grey, cv::Matx<float, 1, 3>(1.0f / 3, 1.0f / 3, 1.0f / 3));
  return grey;
}

Result<formats::AtomicDirectory::Existing> check_tile_output(const fs::path& output) {
  std::error_code ec;
  const auto status = fs::symlink_status(output, ec);
  if (!fs::exists(status)) return formats::AtomicDirectory::Existing::refuse;
  if (fs::is_directory(status) && fs::is_empty(output, ec) && !ec)
    return formats::AtomicDirectory::Existing::replace;
  std::ifstream in(output / formats::tile_files::kDescription);
  const nlohmann::json doc = nlohmann::json::parse(in, nullptr, false);
  if (fs::is_directory(status) && doc.is_object() &&
      doc.value("format", "") == formats::tile_files::kFormat)
    return formats::AtomicDirectory::Existing::replace;
  return std::unexpected(bad_input(output, "",
                                   "exists and is not a psrig tile directory; refusing to replace "
                                   "it (choose another --out)"));
}

// The frames a lattice allows: nu x nv repeats of u and v, up to as many as
// could fit, or `repeats` each way when asked.
struct FrameSearch {
  cv::Point2d u, v;
  int most_u = 1, most_v = 1;
  int repeats = 0;  // 0: as many as fit
  cv::Size scan;

  [[nodiscard]] bool allows(int nu, int nv) const {
    return !(repeats > 0 && (nu != repeats || nv != repeats));
  }
};

// As many whole repeats as fit with the band (or as asked), the largest area.
std::optional<Frame> largest_frame(const FrameSearch& search) {
  std::optional<Frame> best;
  for (int nu = 1; nu <= search.most_u; ++nu) {
    for (int nv = 1; nv <= search.most_v; ++nv) {
      if (!search.allows(nu, nv)) continue;
      const Frame f = periodic_frame(search.u, search.v, nu, nv, search.scan);
      if (!fits(f, search.scan)) continue;
      if (!best || nu * nv > best->nu * best->nv) best = f;
    }
  }
  return best;
}

// The smoothest cut (a whole number of tile pixels along each direction
// from the frame's origin), as a point of the scan; every lattice translate
// of it is as good.
cv::Point2d smoothest_cut(const formats::Maps& maps, const Frame& frame) {
  cv::Mat mx, my, probe;
  sampling_maps(frame, mx, my);
  cv::remap(maps.height.empty() ? grey_of(maps.albedo) : maps.height, probe, mx, my,
            cv::INTER_LINEAR, cv::BORDER_REFLECT);
  probe = probe(cv::Rect(frame.band, frame.band, frame.width, frame.height));
  const int du = smoothest_phase(probe, frame.nu, true);
  const int dv = smoothest_phase(probe, frame.nv, false);
  const cv::Point2d step_u = frame.nu * frame.u / frame.width;
  const cv::Point2d step_v = frame.nv * frame.v / frame.height;
  return frame.origin + du * step_u + dv * step_v;
}

// The largest frame starting on a lattice translate of `cut` that fits.
std::optional<Frame> frame_at_cut(const FrameSearch& search, cv::Point2d cut) {
  const cv::Point2d u = search.u, v = search.v;
  std::optional<Frame> chosen;
  const double det = cross(u, v);
  for (int nu = 1; nu <= search.most_u; ++nu) {
    for (int nv = 1; nv <= search.most_v; ++nv) {
      if (!search.allows(nu, nv)) continue;
      if (chosen && nu * nv <= chosen->nu * chosen->nv) continue;
      Frame f = periodic_frame(u, v, nu, nv, search.scan);
      const cv::Point2d d = f.origin - cut;
      const double su = cross(d, v) / det, sv = cross(u, d) / det;
      for (const double ku : {std::floor(su), std::ceil(su)}) {
        bool done = false;
        for (const double kv : {std::floor(sv), std::ceil(sv)}) {
          Frame g = f;
          g.origin = cut + ku * u + kv * v;
          if (fits(g, search.scan)) {
            chosen = g;
            done = true;
            break;
          }
        }
        if (done) break;
      }
    }
  }
  return chosen;
}

// Where the tile lies: whole repeats of the lattice cut where the fabric is
// smoothest, else the whole scan (tile.message says why, tile.periodic
// which).
Result<Frame> choose_frame(const formats::Maps& maps, const std::optional<RepeatLattice>& lattice,
                           const TileOptions& options, Tile& tile) {
  const cv::Size scan = maps.p.size();
  Frame frame;
  if (lattice) {
    const cv::Point2d u = lattice->u_px, v = lattice->v_px;
    const int most_u = static_cast<int>(scan.width / std::max(1.0, std::abs(u.x))) + 1;
    const int most_v = static_cast<int>(scan.height / std::max(1.0, std::abs(v.y))) + 1;
    const FrameSearch search{u, v, most_u, most_v, options.repeats, scan};
    std::optional<Frame> best = largest_frame(search);
    if (!best && options.repeats > 0)
      return std::unexpected(
          bad_input({}, "--repeats",
                    std::to_string(options.repeats) + " repeats each way do not fit in the scan (" +
                        std::to_string(scan.width) + "x" + std::to_string(scan.height) +
                        " px, repeat " + std::to_string(static_cast<int>(norm(u))) + "x" +
                        std::to_string(static_cast<int>(norm(v))) + " px); ask for fewer"));
    if (best) {
      // Cut where the fabric is smoothest when the shifted frame still fits.
      const std::optional<Frame> chosen = frame_at_cut(search, smoothest_cut(maps, *best));
      if (chosen) *best = *chosen;
      frame = *best;
      tile.periodic = true;
    } else {
      tile.message = "the repeat is too large for a whole one to fit with its blend band";
    }
  } else {
    tile.message = "no repeat found";
  }
  if (!tile.periodic) {
    frame = whole_scan_frame(scan);
    tile.message += ": the tile is the whole scan with its border cross-faded";
  }
  return frame;
}

// How the tile's pixels lie on the scan's: the Jacobian J of tile pixels to
// scan pixels (its columns ju and jv), and the scan pixels per tile pixel
// along the tile's x and y.
struct TileScale {
  double scale_x = 1, scale_y = 1;
  double course_spacing = 0;
  cv::Point2d ju, jv;
};

TileScale tile_scale(const Frame& frame) {
  TileScale s;
  s.scale_x = frame.nu * norm(frame.u) / frame.width;  // scan px per tile px along x
  s.course_spacing = std::abs(cross(frame.u, frame.v)) / norm(frame.u);
  s.scale_y = frame.nv * s.course_spacing / frame.height;
  s.ju = frame.nu * frame.u / frame.width;
  s.jv = frame.nv * frame.v / frame.height;
  return s;
}

// The maps resampled onto the tile's pixels, band included, before the
// cross-fade.
struct Resampled {
  cv::Mat p, q, height, albedo, valid;
};

// The plane through the tile's heights comes off, from the gradients
// too: a residual tilt would otherwise step the height at the seam.
void remove_plane(cv::Mat& height, cv::Mat& tp, cv::Mat& tq, const TileScale& s, double px) {
  cv::Matx33d normal = cv::Matx33d::zeros();
  cv::Vec3d rhs;
  for (int r = 0; r < height.rows; ++r)
    for (int c = 0; c < height.cols; ++c) {
      const float z = height.at<float>(r, c);
      if (!std::isfinite(z)) continue;
      const cv::Vec3d x(1, c, r);
      normal += x * x.t();
      rhs += z * x;
    }
  cv::Vec3d plane;
  if (cv::solve(normal, rhs, plane, cv::DECOMP_CHOLESKY)) {
    for (int r = 0; r < height.rows; ++r)
      for (int c = 0; c < height.cols; ++c)
        height.at<float>(r, c) -= static_cast<float>(plane[0] + plane[1] * c + plane[2] * r);
    // Heights per tile pixel, gradients per unit length.
    tp -= plane[1] / (s.scale_x * px);
    tq += plane[2] / (s.scale_y * px);
  }
}

Resampled resample_maps(const formats::Maps& maps, const Frame& frame, const TileScale& s) {
  cv::Mat mx, my;
  sampling_maps(frame, mx, my);
  const auto sample = [&](const cv::Mat& src, int interpolation) {
    cv::Mat out;
    cv::remap(src, out, mx, my, interpolation, cv::BORDER_REFLECT);
    return out;
  };

  // Gradients follow the resampling: the tile's axes are the scan's u and v
  // directions scaled, so its gradient is J^T times the scan's, J the
  // Jacobian of tile pixels to scan pixels (rows down: dz/drow = -q).
  const double px = maps.pixel_size_mm.value_or(1.0);
  cv::Mat p = sample(maps.p, cv::INTER_CUBIC);
  cv::Mat q = sample(maps.q, cv::INTER_CUBIC);
  Resampled resampled;
  resampled.p.create(p.size(), CV_32F);
  resampled.q.create(p.size(), CV_32F);
  for (int r = 0; r < p.rows; ++r) {
    for (int c = 0; c < p.cols; ++c) {
      const double gx = p.at<float>(r, c), gy = -q.at<float>(r, c);  // per unit length, rows down
      resampled.p.at<float>(r, c) = static_cast<float>((s.ju.x * gx + s.ju.y * gy) / s.scale_x);
      resampled.q.at<float>(r, c) = static_cast<float>(-(s.jv.x * gx + s.jv.y * gy) / s.scale_y);
    }
  }
  if (!maps.height.empty()) {
    resampled.height = sample(maps.height, cv::INTER_CUBIC);
    remove_plane(resampled.height, resampled.p, resampled.q, s, px);
  }
  resampled.albedo = sample(maps.albedo, cv::INTER_CUBIC);
  maps.mask.convertTo(resampled.valid, CV_32F, 1.0 / 255);
  resampled.valid = sample(resampled.valid, cv::INTER_NEAREST);
  return resampled;
}

// The tile's maps, cross-faded, and what the tile says of itself: where it
// lies, its size and its seam.
void fill_tile(Tile& tile, const formats::Maps& maps, const Frame& frame, const TileScale& s,
               const Resampled& resampled) {
  const double px = maps.pixel_size_mm.value_or(1.0);
  const auto fade = [&](const cv::Mat& e) {
    return cross_fade(e, frame.width, frame.height, frame.band);
  };
  formats::Maps& out = tile.maps;
  out.directory = maps.directory;  // the source, for tile.json
  out.pixel_size_mm =
      maps.pixel_size_mm ? std::optional<double>(*maps.pixel_size_mm * s.scale_x) : std::nullopt;
  out.height_units = maps.height_units;
  out.p = fade(resampled.p);
  out.q = fade(resampled.q);
  out.albedo = cv::max(fade(resampled.albedo), 0.0);
  if (!resampled.height.empty()) out.height = fade(resampled.height);
  const cv::Mat faded = fade(resampled.valid);
  out.mask = faded >= 0.999f;  // valid only where both sides were

  tile.repeats_u = frame.nu;
  tile.repeats_v = frame.nv;
  tile.origin_px = frame.origin;
  tile.u_px = frame.u;
  tile.v_px = frame.v;
  tile.band_px = frame.band;
  tile.pixel_size_mm = out.pixel_size_mm;
  tile.width = frame.nu * norm(frame.u) * px;
  tile.height = frame.nv * s.course_spacing * px;
  // The height's seam where it has one; a scan whose height is NaN along
  // the border (outside its mask) is checked on the albedo instead.
  tile.seam = out.height.empty() ? SeamCheck{} : check_seam(out.height, "height");
  const long seam_samples = 2L * (out.p.rows + out.p.cols) * 2;  // four lines of the 2x2
  if (out.height.empty() || tile.seam.samples < seam_samples / 2)
    tile.seam = check_seam(grey_of(out.albedo), "albedo");
}

}  // namespace

SeamCheck check_seam(const cv::Mat& map, const std::string& name) {
  SeamCheck check;
  check.map = name;
  if (map.cols < 4 || map.rows < 4) return check;
  cv::Mat twice;
  cv::repeat(map, 2, 2, twice);
  const int w = map.cols, h = map.rows;
  long finite = 0;
  check.value =
      std::max({line_rms(twice, w - 1, true, &finite), line_rms(twice, w, true, &finite),
                line_rms(twice, h - 1, false, &finite), line_rms(twice, h, false, &finite)});
  check.samples = finite;
  std::vector<double> inside;
  for (int c = 1; c < w - 1; ++c)
    inside.push_back(line_rms(map, c, true));
  for (int r = 1; r < h - 1; ++r)
    inside.push_back(line_rms(map, r, false));
  const auto at = inside.begin() + static_cast<long>(0.95 * static_cast<double>(inside.size() - 1));
  std::nth_element(inside.begin(), at, inside.end());
  check.bound = *at;
  return check;
}

Result<Tile> make_seamless_tile(const formats::Maps& maps,
                                const std::optional<RepeatLattice>& lattice,
                                const TileOptions& options) {
  const cv::Size scan = maps.p.size();
  if (scan.width < 16 || scan.height < 16)
    return std::unexpected(bad_input(maps.directory, "", "the maps are too small to tile"));
  Tile tile;
  const auto frame = choose_frame(maps, lattice, options, tile);
  if (!frame) return std::unexpected(frame.error());
  const TileScale scale = tile_scale(*frame);
  fill_tile(tile, maps, *frame, scale, resample_maps(maps, *frame, scale));
  return tile;
}

nlohmann::json tile_json(const Tile& tile) {
  const bool mm = tile.pixel_size_mm.has_value();
  nlohmann::json j;
  j["format"] = formats::tile_files::kFormat;
  j["source"] =
      tile.maps.directory.empty() ? nlohmann::json() : nlohmann::json(tile.maps.directory.string());
  j["width_px"] = tile.maps.p.cols;
  j["height_px"] = tile.maps.p.rows;
  j["pixel_size_mm"] = mm ? nlohmann::json(*tile.pixel_size_mm) : nlohmann::json();
  j["width_mm"] = mm ? nlohmann::json(tile.width) : nlohmann::json();
  j["height_mm"] = mm ? nlohmann::json(tile.height) : nlohmann::json();
  j["units"] = mm ? "mm" : "px";
  j["height_units"] =
      tile.maps.height.empty() ? nlohmann::json() : nlohmann::json(tile.maps.height_units);
  j["repeats"] = {tile.repeats_u, tile.repeats_v};
  j["lattice"] = {{"u_px", {tile.u_px.x, tile.u_px.y}},
                  {"v_px", {tile.v_px.x, tile.v_px.y}},
                  {"origin_px", {tile.origin_px.x, tile.origin_px.y}}};
  j["periodic"] = tile.periodic;
  if (!tile.message.empty()) j["message"] = tile.message;
  j["blend"] = {{"method",
                 "raised-cosine cross-fade with the continuation one tile away; plane "
                 "removed from the height"},
                {"band_px", tile.band_px}};
  j["seam"] = {
      {"statistic", "RMS over a line of the second difference of the " + tile.seam.map +
                        " across it; value: worst line straddling a seam of the tile repeated 2x2"},
      {"bound", tile.seam.bound},
      {"bound_is", "95th percentile of the same statistic over the tile's interior lines"},
      {"value", tile.seam.value},
      {"map", tile.seam.map},
      {"samples", tile.seam.samples},
      {"passed", tile.seam.passed()}};
  return j;
}

Status write_tile(const Tile& tile, const fs::path& directory,
                  const formats::StorageOptions& storage) {
  const auto existing = check_tile_output(directory);
  if (!existing) return std::unexpected(existing.error());
  auto staging = formats::AtomicDirectory::create(directory);
  if (!staging) return std::unexpected(staging.error());
  const fs::path dir = staging->path();
  const formats::Maps& m = tile.maps;
  const std::vector<int> png = formats::png_params(storage.png_level);
  const std::vector<int> half = formats::exr_params(storage.exr_compression, true);
  const std::vector<int> map_exr = formats::exr_params(
      storage.exr_compression, storage.map_precision == formats::MapPrecision::half);
  if (auto ok = formats::write_image(dir / formats::map_files::kAlbedoPng,
                                     formats::encode_albedo_srgb8(m.albedo), png);
      !ok)
    return ok;
  if (auto ok = formats::write_image(dir / formats::map_files::kAlbedoExr, m.albedo, half); !ok)
    return ok;
  if (auto ok = formats::write_image(dir / formats::map_files::kNormalPng,
                                     formats::encode_normal16(m.p, m.q), png);
      !ok)
    return ok;
  if (auto ok = formats::write_image(dir / formats::map_files::kP, m.p, map_exr); !ok) return ok;
  if (auto ok = formats::write_image(dir / formats::map_files::kQ, m.q, map_exr); !ok) return ok;
  if (!m.height.empty()) {
    if (auto ok = formats::write_image(dir / formats::map_files::kHeightExr, m.height, map_exr);
        !ok)
      return ok;
    const cv::Mat finite = m.height == m.height;
    double low = 0, high = 0;
    if (cv::countNonZero(finite) > 0)
      cv::minMaxLoc(m.height, &low, &high, nullptr, nullptr, finite);
    cv::Mat height16 = formats::encode_height16(m.height, low, high);
    height16.setTo(0, ~finite);
    if (auto ok = formats::write_image(dir / formats::map_files::kHeightPng, height16, png); !ok)
      return ok;
  }
  if (auto ok = formats::write_image(dir / formats::map_files::kMask, m.mask, png); !ok) return ok;
  const fs::path json_path = dir / formats::tile_files::kDescription;
  std::ofstream out(json_path);
  out << tile_json(tile).dump(2) << '\n';
  out.close();
  if (!out) return std::unexpected(io_error(json_path, "cannot write"));
  return staging->commit(*existing, false);
}

Result<Tile> cut_tile(const formats::Maps& maps, const TileOptions& options,
                      std::vector<std::string>& warnings) {
  std::string why;
  const cv::Mat& height = maps.height.empty() ? maps.p : maps.height;
  const auto lattice = find_repeat_lattice(height, maps.albedo, &why);
  if (!lattice && options.repeats > 0)
    return std::unexpected(
        bad_input({}, "--repeats", why + "; --repeats needs a repeating fabric"));
  auto tile = make_seamless_tile(maps, lattice, options);
  if (!tile) return tile;
  if (!tile->periodic)
    warnings.push_back(why.empty() ? tile->message
                                   : why +
                                         "; the tile is the whole scan with its border "
                                         "cross-faded");
  if (!tile->seam.passed())
    warnings.push_back("the seam's second difference " + std::to_string(tile->seam.value) +
                       " exceeds the interior's 95th percentile " +
                       std::to_string(tile->seam.bound));
  return tile;
}

std::optional<fs::path> stored_tile(const fs::path& maps_directory) {
  const fs::path directory = maps_directory / formats::tile_files::kDirectory;
  std::error_code tile_ec;
  std::error_code maps_ec;
  const auto made = fs::last_write_time(directory / formats::tile_files::kDescription, tile_ec);
  const auto maps = fs::last_write_time(maps_directory / formats::map_files::kReport, maps_ec);
  if (!tile_ec && (maps_ec || made >= maps)) return directory;
  return std::nullopt;
}

}  // namespace psrig::analysis
