#include "psrig/cloth/woven_neural_render.h"

#include <cmath>

#include "psrig/base/parallel.h"

namespace psrig::cloth {

WovenLookup footprint_lookup(const Footprint& footprint, const Eigen::Vector2f& repeat_size) {
  WovenLookup lookup;
  const float u = footprint.centre.x() / repeat_size.x();
  const float v = footprint.centre.y() / repeat_size.y();
  lookup.u = u - std::floor(u);
  lookup.v = v - std::floor(v);
  const float area = std::abs(footprint.edge_u.x() * footprint.edge_v.y() -
                              footprint.edge_u.y() * footprint.edge_v.x());
  lookup.size = std::sqrt(area / (repeat_size.x() * repeat_size.y()));
  return lookup;
}

WovenImage render_woven_neural(const WovenNetwork& network, const WovenDecoderMaterial& material,
                               const Eigen::Vector2f& repeat_size, const YarnColours& colours,
                               const WovenView& view, const WovenLight& light, int width,
                               int height) {
  if (width <= 0 || height <= 0) return {};
  return render_woven_neural(network, material, repeat_size, colours,
                             WovenCamera::look(view, width, height), light);
}

WovenImage render_woven_neural(const WovenNetwork& network, const WovenDecoderMaterial& material,
                               const Eigen::Vector2f& repeat_size, const YarnColours& colours,
                               const WovenCamera& camera, const WovenLight& light) {
  WovenImage image;
  const int width = camera.width, height = camera.height;
  if (width <= 0 || height <= 0) return image;
  image.width = width;
  image.height = height;
  image.rgb.assign(static_cast<std::size_t>(width) * height * 3, 0);
  const Eigen::Vector3f wi = light.direction.normalized();
  parallel_chunks(height, 1, [&](int begin, int end) {
    for (int y = begin; y < end; ++y)
      for (int x = 0; x < width; ++x) {
        const std::optional<Footprint> footprint = camera.pixel_footprint(x, y);
        if (!footprint) continue;
        const Eigen::Vector3f wo = -camera.ray(x + 0.5f, y + 0.5f);
        WovenLookup lookup = footprint_lookup(*footprint, repeat_size);
        lookup.wi = {wi.x(), wi.y(), wi.z()};
        lookup.wo = {wo.x(), wo.y(), wo.z()};
        const WovenComponents c = network.decode(material, lookup);
        const Eigen::Vector3f value =
            light.irradiance *
            woven_bsdf_colour(c, colours);
        const std::size_t i = (static_cast<std::size_t>(y) * width + x) * 3;
        image.rgb[i] = value.x();
        image.rgb[i + 1] = value.y();
        image.rgb[i + 2] = value.z();
      }
  });
  return image;
}

}  // namespace psrig::cloth
