#include "far_level.h"

#include <GLES3/gl3.h>
#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>

#include "psrig/preview/clear_frame.h"
#include "psrig/preview/repeat_maps.h"
#include "psrig/preview/yarn_slice.h"

namespace psrig::preview {
namespace {

// The next power of two, within [4, 1024]: texels along one side of the repeat.
int repeat_side(float texels) {
  const auto wanted = static_cast<unsigned>(std::clamp(std::ceil(texels), 4.0f, 1024.0f));
  return static_cast<int>(std::bit_ceil(wanted));
}

// The mean linear colour of a bake's texels (repeat_texels), RGB.
Eigen::Vector3f mean_colour(const cv::Mat& texels) {
  const cv::Scalar mean = cv::mean(texels);
  return {static_cast<float>(mean[0]), static_cast<float>(mean[1]), static_cast<float>(mean[2])};
}

// The points of `mesh` where FarCloth's shade grid lies: its corners, the
// middles of its sides and its middle, each bilinear between vertices.
std::array<Eigen::Vector3f, FarCloth::kShadeGrid * FarCloth::kShadeGrid> shade_grid_points(
    const cloth::StitchMesh& mesh) {
  std::array<Eigen::Vector3f, FarCloth::kShadeGrid * FarCloth::kShadeGrid> points;
  constexpr float kLast = FarCloth::kShadeGrid - 1;
  for (int j = 0; j < FarCloth::kShadeGrid; ++j)
    for (int i = 0; i < FarCloth::kShadeGrid; ++i) {
      const float u = static_cast<float>(i * mesh.columns) / kLast;
      const float v = static_cast<float>(j * mesh.rows) / kLast;
      const int c = static_cast<int>(u), r = static_cast<int>(v);
      const int c1 = std::min(c + 1, mesh.columns), r1 = std::min(r + 1, mesh.rows);
      const float s = u - static_cast<float>(c), t = v - static_cast<float>(r);
      points[static_cast<std::size_t>(j * FarCloth::kShadeGrid + i)] =
          (1 - t) * ((1 - s) * mesh.vertex(c, r) + s * mesh.vertex(c1, r)) +
          t * ((1 - s) * mesh.vertex(c, r1) + s * mesh.vertex(c1, r1));
    }
  return points;
}

// How far match_scan() may take the yarns' colour.
constexpr float kLeastAlbedoGain = 0.05f, kMostAlbedoGain = 4.0f;

// Every face within `degrees` of facing as the window does: the bake is lit
// and seen as the window is, so it stands for flat cloth only (a drape's
// folds would all be shaded alike: they get the repeat's maps instead).
bool flat_like(const cloth::StitchMesh& mesh, const Eigen::Vector3f& normal, float degrees) {
  const float least = std::cos(degrees * std::numbers::pi_v<float> / 180);
  for (int row = 0; row < mesh.rows; ++row)
    for (int column = 0; column < mesh.columns; ++column) {
      const Eigen::Vector3f face =
          (mesh.vertex(column + 1, row + 1) - mesh.vertex(column, row))
              .cross(mesh.vertex(column, row + 1) - mesh.vertex(column + 1, row));
      if (face.squaredNorm() > 0 && face.normalized().dot(normal) < least) return false;
    }
  return true;
}

// How scan_surface.frag lights the scan's or the repeat's maps: the
// yarns' lamp colour, the swatch's weights.
ShadingParams surface_shading(const YarnRendererOptions& options) {
  ShadingParams shading;
  shading.light_colour = {options.shading.light_colour.x(), options.shading.light_colour.y(),
                          options.shading.light_colour.z()};
  return shading;
}

}  // namespace

Result<std::unique_ptr<FarLevel>> FarLevel::create(const YarnRendererOptions& options) {
  std::unique_ptr<FarLevel> far(new FarLevel);
  far->options_ = options;
  // The bake is the near level: what the far level must equal, filtered.
  YarnRendererOptions near = options;
  near.level = YarnLevel::near;
  near.encode_srgb = false;  // bakes go to an sRGB target
  auto baker = YarnRenderer::create(near);
  if (!baker) return std::unexpected(baker.error());
  far->baker_ = std::move(*baker);
  auto cloth = FarCloth::create();
  if (!cloth) return std::unexpected(cloth.error());
  far->cloth_ = std::move(*cloth);
  return far;
}

bool FarLevel::same_shape(const RepeatWindow& window) const {
  if (!taken_window_) return false;
  const RepeatWindow& taken = *taken_window_;
  const float strain = options_.rebake_strain;
  return window.first_column == taken.first_column && window.first_row == taken.first_row &&
         window.columns == taken.columns && window.rows == taken.rows &&
         (window.across - taken.across).norm() <= strain * taken.across.norm() &&
         (window.up - taken.up).norm() <= strain * taken.up.norm();
}

Status FarLevel::use_scan(const PatchTile& tile) {
  auto scan = ScanSurface::create(tile, surface_shading(options_));
  if (!scan) return std::unexpected(scan.error());
  scan_ = std::move(*scan);
  scan_mesh_ = false;
  return {};
}

bool FarLevel::update_surface(const cloth::YarnSurface& surface) {
  if (!scan_) return false;
  scan_mesh_ = surface.mesh.columns > 0 && surface.mesh.rows > 0;
  if (scan_mesh_) scan_->update(surface.mesh, options_.environment, options_.shading.environment);
  return scan_mesh_;
}

Status FarLevel::set_woven(const WovenFarMaterial& material, const std::filesystem::path& weights) {
  if (!woven_) {
    auto network = cloth::WovenNetwork::load(weights);
    if (!network) return std::unexpected(network.error());
    auto woven =
        WovenFarCloth::create(std::make_shared<const cloth::WovenNetwork>(std::move(*network)));
    if (!woven) return std::unexpected(woven.error());
    woven_ = std::move(*woven);
  }
  return woven_->set_material(material);
}

void FarLevel::take_yarns(const cloth::YarnSet& yarns) {
  const bool same_style = taken_window_ && same_slice(yarns.style, near_yarns_.style) &&
                          yarns.style.colour == near_yarns_.style.colour;
  if (!same_style) {
    draped_.reset();
    draped_baked_.reset();
  }
  if (!same_style || !same_shape(*window_)) {
    // A margin of what can show or shadow in the window: a few yarns.
    near_yarns_ = window_yarns(yarns, *window_, 8 * yarns.style.radius_mm);
    taken_window_ = window_;
    baker_stale_ = true;
    baked_.reset();
    draped_baked_.reset();  // the draped maps were made of the old yarns too
    matched_light_.reset();
  }
}

bool FarLevel::update(const cloth::YarnSet& yarns) {
  if (scan_) {
    // The yarns about the middle repeat, for match_scan().
    if ((window_ = middle_repeat(yarns.surface))) take_yarns(yarns);
    return update_surface(yarns.surface);
  }
  window_ = middle_repeat(yarns.surface);
  if (!window_) return false;
  draped_now_ = !flat_like(yarns.surface.mesh, window_->normal(), options_.far_cloth_flat_degrees);
  // The neural level is for flat weaves, as the bake is without the maps.
  if (draped_now_ && (woven_ || !options_.far_cloth_draped_maps)) {
    window_.reset();
    return false;
  }
  if (woven_) {  // nothing to bake
    woven_->update(yarns.surface);
    return true;
  }
  take_yarns(yarns);
  if (draped_now_) {
    draped_mesh_ = yarns.surface.mesh;
    if (draped_)
      draped_->update(draped_mesh_, options_.environment,
                      options_.shading.environment * draped_gain_);
    return true;
  }
  cloth_->update(yarns.surface, *window_);
  shade_points_ = shade_grid_points(yarns.surface.mesh);
  return true;
}

bool FarLevel::stands_for(const BakeKey& key, const std::optional<BakeKey>& baked) const {
  if (!baked) return false;
  const float most = options_.rebake_degrees * std::numbers::pi_v<float> / 180;
  const auto turned = [](const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
    return std::acos(std::clamp(a.dot(b), -1.0f, 1.0f));
  };
  return turned(key.toward_eye, baked->toward_eye) <= most &&
         turned(key.normal, baked->normal) <= most &&
         (key.light - baked->light).cwiseAbs().maxCoeff() < 1e-4f &&
         key.shadows == baked->shadows && key.fibre_detail == baked->fibre_detail;
}

void FarLevel::prepare(const KnitFrame& frame, const KnitView& view, unsigned target,
                       cv::Size viewport) {
  frame_target_ = target;
  frame_viewport_ = viewport;
  if (scan_ || !window_ || woven_) return;
  const Eigen::Vector3f toward_eye = frame.orthographic
                                         ? (frame.eye - frame.centre).normalized()
                                         : (frame.eye - window_->centre()).normalized();
  // Rebaked as the middle repeat turns too (a swinging drape), so that it
  // is drawn as the near level draws it: the bake is lit as the repeat
  // faced.
  const BakeKey key{toward_eye, window_->normal(), frame.light, view.shadows, view.fibre_detail};
  if (draped_now_) {
    if (draped_ && stands_for(key, draped_baked_)) return;
    // A failed bake is not recorded: the next frame tries again.
    if (bake_draped(frame, view, toward_eye)) draped_baked_ = key;
  } else {
    if (stands_for(key, baked_)) return;
    if (bake(frame, view, toward_eye)) baked_ = key;
  }
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, static_cast<GLuint>(target));
  glViewport(0, 0, viewport.width, viewport.height);
}

std::optional<ColourMatch> FarLevel::match_scan(const KnitFrame& frame, const KnitView& view,
                                                unsigned target, cv::Size viewport) {
  if (!scan_ || !scan_mesh_ || !taken_window_ || near_yarns_.curves.empty()) return std::nullopt;
  if (matched_light_ && (*matched_light_ - frame.light).cwiseAbs().maxCoeff() < 1e-4f)
    return std::nullopt;
  const Eigen::Vector3f toward_eye = frame.orthographic
                                         ? (frame.eye - frame.centre).normalized()
                                         : (frame.eye - taken_window_->centre()).normalized();
  std::optional<KnitFrame> baking = bake_frame(frame, toward_eye);
  if (!baking) return std::nullopt;
  // The scan over the window as the bakes see it, over black.
  target_->bind();
  clear_frame({0, 0, 0}, false, target_->size());
  scan_->draw(*baking, {.yarn_width_mm = 2 * near_yarns_.style.radius_mm,
                        .from_px = 2e9f,
                        .full_px = 1e9f});
  const cv::Mat scan_frame = target_->read();
  const Eigen::Vector3f scan = mean_colour(repeat_texels(scan_frame, scan_frame));
  // The yarns' mean as the far level's bakes draw them.
  const auto yarns_at = [&](const ColourMatch& match) -> std::optional<Eigen::Vector3f> {
    baker_->set_colour_match(match);
    return bake_mean(frame, view, toward_eye);
  };
  ColourMatch match;
  const auto full = yarns_at(match);
  const auto dull = yarns_at({.sheen_gain = 0});
  if (!full || !dull) return std::nullopt;
  // The sheen is white and the same whatever the colour: where it alone
  // outshines a channel of the scan, no colour would do, so it is dimmed
  // to leave that channel a tenth for the yarns' own colour.
  const Eigen::Vector3f sheen = (*full - *dull).cwiseMax(0.0f);
  for (int c = 0; c < 3; ++c)
    if (sheen[c] > 1e-6f) match.sheen_gain = std::min(match.sheen_gain, 0.9f * scan[c] / sheen[c]);
  // Then per channel the secant twice, from the colour as given and half
  // of it: the yarns' shading is nearly linear in their colour (light
  // scattered between fibres grows faster).
  ColourMatch low = match, high = match;
  low.albedo_gain.setConstant(0.5f);
  std::optional<Eigen::Vector3f> at_low = yarns_at(low), at_high = yarns_at(high);
  for (int round = 0; round < 2 && at_low && at_high; ++round) {
    for (int c = 0; c < 3; ++c) {
      const float run = high.albedo_gain[c] - low.albedo_gain[c];
      const float slope = std::abs(run) > 1e-6f ? ((*at_high)[c] - (*at_low)[c]) / run : 0.0f;
      if (slope > 1e-6f)
        match.albedo_gain[c] =
            std::clamp(high.albedo_gain[c] + (scan[c] - (*at_high)[c]) / slope, kLeastAlbedoGain,
                       kMostAlbedoGain);
    }
    if (round == 1) break;
    low = high;
    at_low = at_high;
    high = match;
    at_high = yarns_at(high);
  }
  baker_->set_colour_match({});
  if (!at_low || !at_high) return std::nullopt;
  matched_light_ = frame.light;
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, static_cast<GLuint>(target));
  glViewport(0, 0, viewport.width, viewport.height);
  return match;
}

void FarLevel::draw(const KnitFrame& frame, const FarClothDraw& how) const {
  if (scan_) {
    scan_->draw(frame, how);
    return;
  }
  if (draped_now_) {  // never the flat bake on a draped mesh, even if the maps failed
    if (draped_) draped_->draw(frame, how);
    return;
  }
  if (!woven_) {
    cloth_->draw(frame, how);
    return;
  }
  woven_->draw(frame, {.fade = how,
                       .irradiance = options_.woven_irradiance,
                       .decode_scale = options_.woven_decode_scale,
                       .target = frame_target_,
                       .viewport = frame_viewport_});
}

// The frame that draws the taken window onto the bake's target (made at
// its size): the repeat at `bake_yarn_texels` a yarn, rounded up to whole
// powers of two a side. Nullopt when no target can be made.
std::optional<KnitFrame> FarLevel::bake_frame(const KnitFrame& frame,
                                              const Eigen::Vector3f& toward_eye) {
  if (baker_stale_) {
    baker_->update(near_yarns_);
    baker_stale_ = false;
  }
  const RepeatWindow& window = *taken_window_;
  const float yarn_mm = 2 * near_yarns_.style.radius_mm;
  const float wanted = options_.bake_yarn_texels / yarn_mm;
  const cv::Size size(repeat_side(window.across.norm() * wanted),
                      repeat_side(window.up.norm() * wanted));
  const float texels_per_mm = std::min(static_cast<float>(size.width) / window.across.norm(),
                                       static_cast<float>(size.height) / window.up.norm());
  const float depth_mm = 0.5f * std::max(window.across.norm(), window.up.norm()) + 4 * yarn_mm;
  KnitFrame baking = repeat_frame(frame, window, toward_eye, texels_per_mm, depth_mm);
  // The near level's choices (halo, fibre detail, pieces, the shadow map's
  // share) as where the far level begins to take over from it, so that the
  // two agree there; the texels are finer, as a frame drawn finer and
  // filtered down is.
  baking.focal_px = options_.far_cloth_from_px / yarn_mm;
  if (!target_ || target_->size() != size) {
    auto made = OffscreenTarget::create(size, 4, ColourStorage::srgb);
    if (!made) return std::nullopt;
    target_ = std::move(*made);
  }
  return baking;
}

// The repeat drawn at the near level over black and over white, 4x
// multisampled as the near level's frames are, at `bake_phases` phases of
// the yarns' slice, averaged: every repeat of the cloth has its yarns at
// phases of their own, so the one texture that is nearest them all is
// their mean (what one bake shows at one phase is as far from each repeat
// as two repeats are from each other).
cv::Mat FarLevel::bake_texels(const KnitFrame& frame, const KnitView& view,
                              const Eigen::Vector3f& toward_eye, int phases) {
  std::optional<KnitFrame> baking = bake_frame(frame, toward_eye);
  if (!baking) return {};
  const cv::Size size = target_->size();
  phases = std::max(phases > 0 ? phases : options_.bake_phases, 1);
  // Steps of a whole slice over `phases` and of a ply's turn over `phases`
  // at once: the plies' pattern repeats many times along the slice, so
  // steps of the slice alone could all land on the same ply phase.
  const float step = (1 + 1.0f / static_cast<float>(baker_->slice().ply_repeats)) /
                     static_cast<float>(phases);
  cv::Mat sum(size, CV_32FC4, cv::Scalar::all(0));
  KnitView over = view;
  for (int phase = 0; phase < phases; ++phase) {
    baking->slice_phase = static_cast<float>(phase) * step;
    cv::Mat frames[2];
    for (int white = 0; white < 2; ++white) {
      over.background = cv::Vec3f::all(static_cast<float>(white));
      target_->bind();
      baker_->render(*baking, over, size);
      frames[white] = target_->read();
    }
    sum += repeat_texels(frames[0], frames[1]);
  }
  return sum / static_cast<double>(phases);
}

std::optional<Eigen::Vector3f> FarLevel::bake_mean(const KnitFrame& frame, const KnitView& view,
                                                   const Eigen::Vector3f& toward_eye, int phases) {
  const cv::Mat texels = bake_texels(frame, view, toward_eye, phases);
  if (texels.empty()) return std::nullopt;
  return mean_colour(texels);
}

bool FarLevel::bake(const KnitFrame& frame, const KnitView& view,
                    const Eigen::Vector3f& toward_eye) {
  const cv::Mat texels = bake_texels(frame, view, toward_eye);
  if (texels.empty()) return false;
  cloth_->upload(repeat_levels(texels));
  cloth_->set_shade(shade_across(frame, view, toward_eye));
  ++bakes_;
  return true;
}

FarCloth::ShadeGrid FarLevel::shade_across(const KnitFrame& frame, const KnitView& view,
                                           const Eigen::Vector3f& toward_eye) {
  const FarCloth::ShadeGrid uniform = FarCloth::uniform_shade();
  if (frame.orthographic && frame.light.w() == 0) return uniform;  // the same everywhere
  // The yarns baked are the taken window's, which the cloth may have
  // carried since: a place's lamp is moved as that place is from them.
  const Eigen::Vector3f baked_centre = taken_window_->centre();
  const auto mean_at = [&](const Eigen::Vector3f& place) -> std::optional<Eigen::Vector3f> {
    KnitFrame there = frame;
    there.light.head<3>() += frame.light.w() * (baked_centre - place);
    const Eigen::Vector3f eye =
        frame.orthographic ? toward_eye : (frame.eye - place).normalized().eval();
    return bake_mean(there, view, eye, 1);
  };
  const auto middle = mean_at(window_->centre());
  if (!middle) return uniform;
  FarCloth::ShadeGrid shade;
  for (std::size_t k = 0; k < shade.size(); ++k) {
    const auto here = mean_at(shade_points_[k]);
    if (!here) return uniform;
    shade[k] = here->cwiseQuotient(middle->cwiseMax(1e-6f)).cwiseMax(0.25f).cwiseMin(4.0f);
  }
  return shade;
}

// The yarns' own light response for the draped maps
// (ScanSurface::set_light_response), so that a fold turned from the lamp
// keeps the yarns' light, not Lambert's: the repeat baked with a
// directional lamp at each cosine to its plane (about the frame's lamp's
// azimuth; no shadow map, which is drawn for the frame's lamp; one phase:
// only the mean is taken), each over the same at the frame's own lamp,
// is the share of `flat` (what the maps' albedo was divided by) the
// surface must show, less its ambient part, over the direct light's.
std::vector<Eigen::Vector3f> FarLevel::yarn_light_response(const KnitFrame& frame,
                                                           const KnitView& view,
                                                           const Eigen::Vector3f& toward_eye,
                                                           const Eigen::Vector3f& normal,
                                                           const FlatLight& light,
                                                           const Eigen::Vector3f& flat) {
  const Eigen::Vector3f centre = taken_window_->centre();
  const Eigen::Vector3f to_light =
      (frame.light.head<3>() - frame.light.w() * centre).normalized();
  Eigen::Vector3f azimuth = to_light - to_light.dot(normal) * normal;
  if (azimuth.squaredNorm() < 1e-8f) azimuth = taken_window_->across;  // lamp overhead
  azimuth.normalize();
  KnitView unshadowed = view;
  unshadowed.shadows = false;
  const auto mean_lit = [&](const Eigen::Vector3f& toward_light) -> std::optional<Eigen::Vector3f> {
    KnitFrame lit = frame;
    lit.light = Eigen::Vector4f(toward_light.x(), toward_light.y(), toward_light.z(), 0);
    return bake_mean(lit, unshadowed, toward_eye, 1);
  };
  const auto reference = mean_lit(to_light);
  if (!reference) return {};
  const Eigen::Vector3f direct = light.direct.cwiseMax(1e-6f);
  std::vector<Eigen::Vector3f> response;
  for (int k = 0; k < ScanSurface::kResponseSamples; ++k) {
    const float cosine = static_cast<float>(k) / (ScanSurface::kResponseSamples - 1);
    const auto seen = mean_lit(cosine * normal + std::sqrt(1 - cosine * cosine) * azimuth);
    if (!seen) return {};
    const Eigen::Vector3f share = flat.cwiseProduct(seen->cwiseQuotient(reference->cwiseMax(1e-6f)));
    response.push_back((share - light.ambient).cwiseQuotient(direct).cwiseMax(0.0f));
  }
  return response;
}

// As the flat far level bakes it (seen along `toward_eye`, the frame's
// light and shadows), divided by what that light gives a flat white
// surface facing as the repeat did, as scan_surface.frag shades it (front
// ambient from the environment, Lambert with its soft horizon, a point
// light's falloff): drawn on that flat surface the maps are the bake, so
// flat and draped far levels meet without a step.
bool FarLevel::bake_draped(const KnitFrame& frame, const KnitView& view,
                           const Eigen::Vector3f& toward_eye) {
  const RepeatWindow& window = *taken_window_;
  // The side the eye sees: scan_surface.frag shades a back face as the
  // front's mirror, with the environment's light on that side.
  const Eigen::Vector3f normal =
      window.normal().dot(toward_eye) >= 0 ? window.normal() : Eigen::Vector3f(-window.normal());
  const cv::Mat texels = bake_texels(frame, view, toward_eye);
  if (texels.empty()) return false;
  const Eigen::Vector3f to_light = frame.light.head<3>() - frame.light.w() * window.centre();
  const float attenuation =
      frame.light.w() > 0.5f
          ? frame.light_reference_distance * frame.light_reference_distance / to_light.squaredNorm()
          : 1.0f;
  const float cosine = std::max(to_light.normalized().dot(normal), 0.0f);
  const ShadingParams shading = surface_shading(options_);
  const FlatLight light{
      .ambient = options_.shading.environment * options_.environment.lambert(normal),
      .direct = shading.diffuse * attenuation * options_.shading.light_colour};
  const Eigen::Vector3f flat =
      light.ambient + cosine * std::clamp(4 * cosine, 0.0f, 1.0f) * light.direct;
  const cv::Size2f repeat_mm(static_cast<float>(window.columns) * draped_mesh_.face_width_mm,
                             static_cast<float>(window.rows) * draped_mesh_.face_height_mm);
  const RepeatMaps maps =
      repeat_maps(texels, {flat.x(), flat.y(), flat.z()}, repeat_mm);
  // The maps' albedo is stored divided by the gain: the light made brighter.
  ShadingParams brighter = shading;
  brighter.light_colour *= maps.gain;
  const PatchTile tile{.maps = maps.maps, .source = "the chart's repeat", .periodic = true};
  if (draped_) {  // the same textures and program: no shader built again
    if (!draped_->set_tile(tile, brighter)) return false;
  } else {
    auto surface = ScanSurface::create(tile, brighter);
    if (!surface) return false;
    draped_ = std::move(*surface);
  }
  draped_gain_ = maps.gain;
  draped_->set_light_response(yarn_light_response(frame, view, toward_eye, normal, light, flat));
  draped_->update(draped_mesh_, options_.environment, options_.shading.environment * draped_gain_);
  ++bakes_;
  return true;
}

}  // namespace psrig::preview
