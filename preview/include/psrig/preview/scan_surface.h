#pragma once
// The farthest level of cloth a scan feeds (issue 30: `drape MAPS`, `kiosk
// --drape`, `knit --from-scan`): the cloth's stitch mesh drawn as a
// surface with the swatch's own maps (albedo, normals, gloss), the seamless
// tile (patch_tile.h) repeated at its physical size over the mesh at rest,
// lit per pixel as the swatch is (shading.h is the CPU twin, with the
// environment's light as the ambient term) and prefiltered by the normal
// map's mipmaps with the Toksvig term (texture_levels.h). What the kiosk
// shows from afar is then the fabric the technician scanned, draped, not
// a synthetic one. Lit per pixel from the mesh's own normals, it stands for
// draped cloth too, which the baked repeat (repeat_texture.h) cannot.
// Draws into whatever framebuffer is bound; needs its GLES context current
// for its whole life.

#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/cloth/stitch_mesh.h"
#include "psrig/preview/environment_light.h"
#include "psrig/preview/far_cloth.h"
#include "psrig/preview/knit_view.h"
#include "psrig/preview/patch_tile.h"
#include "psrig/preview/shading.h"

namespace psrig::preview {

class ScanSurface {
 public:
  // Bad input when the tile's pixel size is not known (no physical size to
  // tile at). `shading.ambient` is not used: the environment lights it.
  [[nodiscard]] static Result<std::unique_ptr<ScanSurface>> create(const PatchTile& tile,
                                                                   const ShadingParams& shading);
  // Another tile (and its light) from now on, in the same textures and
  // program (no shader built): the vertices' (u, v) follow at the next
  // update(). A tile without a pixel size is refused, changing nothing.
  [[nodiscard]] Status set_tile(const PatchTile& tile, const ShadingParams& shading);
  // The direct light's share by the cosine of the light to the surface's
  // plane, in place of Lambert's with its soft horizon (the tile's normals
  // and gloss then unused): `response[k]` at cosine k / (size - 1), linear
  // between, RGB, times the albedo, `shading.diffuse` and the light.
  // A chart's repeat gets the yarns' own (FarLevel), whose Kajiya-Kay light
  // hardly falls as the cloth turns from the lamp. Empty: Lambert again.
  static constexpr int kResponseSamples = 7;
  void set_light_response(std::vector<Eigen::Vector3f> response);
  ~ScanSurface();
  ScanSurface(const ScanSurface&) = delete;
  ScanSurface& operator=(const ScanSurface&) = delete;

  // The mesh's vertices (every frame while the cloth moves): (u, v) from its
  // faces' rest size, tangent frames from its neighbours, and the light
  // `environment` gives each side (times `environment_scale`).
  void update(const cloth::StitchMesh& mesh, const EnvironmentLight& environment,
              float environment_scale);
  // Over yarns it lies a yarn's width toward the eye, so that their own
  // depth does not hide it, and is depth tested against the rest.
  void draw(const KnitFrame& frame, const FarClothDraw& how) const;

  [[nodiscard]] bool ready() const { return index_count_ > 0; }
  [[nodiscard]] int triangles() const { return index_count_ / 3; }
  [[nodiscard]] cv::Size2d tile_mm() const { return tile_mm_; }

 private:
  struct Gl;
  ScanSurface() = default;
  std::unique_ptr<Gl> gl_;
  ShadingParams shading_;
  cv::Size2d tile_mm_;
  std::vector<float> vertices_;
  int columns_ = -1, rows_ = -1;
  int index_count_ = 0;
  std::vector<Eigen::Vector3f> response_;
};

}  // namespace psrig::preview
