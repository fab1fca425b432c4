#include "psrig/cloth/woven_dataset_generator.h"

#include <cmath>
#include <numbers>

#include "psrig/base/parallel.h"

namespace psrig::cloth {

namespace {

// Keys for mix_seed, so that no two draws share a stream.
enum SeedKey : std::uint64_t { kShapeKey = 1, kAppearanceKey, kFootprintKey, kCentreKey };

// The stratified directions on the front: one jittered (x, y) per cell of a
// grid over [-1, 1]^2, kept where inside the disc and not grazing.
std::vector<Eigen::Vector3f> stratified_directions(int grid, float min_cosine,
                                                   SampleRandom& random) {
  std::vector<Eigen::Vector3f> directions;
  for (int row = 0; row < grid; ++row)
    for (int column = 0; column < grid; ++column) {
      const float x = -1 + 2 * (column + random.uniform()) / grid;
      const float y = -1 + 2 * (row + random.uniform()) / grid;
      const float z2 = 1 - x * x - y * y;
      if (z2 >= min_cosine * min_cosine) directions.emplace_back(x, y, std::sqrt(z2));
    }
  return directions;
}

float footprint_size(int index, int small_sizes, int large_sizes, float max_size, float jitter) {
  if (index < small_sizes) return (index + jitter) / small_sizes;
  return 1 + (max_size - 1) * (index - small_sizes + jitter) / large_sizes;
}

}  // namespace

YarnShape draw_yarn_shape(std::uint64_t seed) {
  SampleRandom random(seed);
  YarnShape shape;
  const int twist = std::min(static_cast<int>(random.uniform() * 3), 2);
  shape.twist_deg = -30.0f + 30.0f * static_cast<float>(twist);
  shape.inclination_deg = 15 + 30 * random.uniform();
  shape.gap_ratio = kWovenGapRatio;
  return shape;
}

WovenMaterialParameters weave_parameters(const WeaveMatrix& weave) {
  WovenMaterialParameters parameters;
  if (weave.roughness > 0) parameters.alpha = weave.roughness;
  if (weave.height_scale > 0) parameters.beta = weave.height_scale;
  return parameters;
}

WovenMaterialParameters draw_appearance(const YarnShape& shape, std::uint64_t seed) {
  SampleRandom random(seed);
  WovenMaterialParameters parameters;
  parameters.shape = shape;
  parameters.alpha = 0.1f + 0.9f * random.uniform();
  parameters.beta = 2 * random.uniform();
  return parameters;
}

Result<WovenMaterialSample> generate_woven_material(const WeaveMatrix& weave,
                                                    const WovenMaterialParameters& parameters,
                                                    int texture_size) {
  if (texture_size <= 0)
    return std::unexpected(bad_input({}, "texture_size", "the texture size must be positive"));
  auto surface = WovenSurface::make(weave, parameters.shape, 1, 1);
  if (!surface) return std::unexpected(surface.error());
  WovenMaterialSample material;
  material.pattern = weave.name;
  material.texture_size = texture_size;
  material.roughness = parameters.alpha;
  material.height_scale = parameters.beta;
  material.twist_deg = parameters.shape.twist_deg;
  material.inclination_deg = parameters.shape.inclination_deg;
  const std::size_t texels = static_cast<std::size_t>(texture_size) * texture_size;
  material.normal.assign(texels * 3, 0);
  material.orientation.assign(texels * 3, 0);
  const Eigen::Vector2f repeat = surface->repeat_size();
  for (int row = 0; row < texture_size; ++row)
    for (int column = 0; column < texture_size; ++column) {
      const Eigen::Vector2f xy((column + 0.5f) / texture_size * repeat.x(),
                               (row + 0.5f) / texture_size * repeat.y());
      const WovenPoint p = surface->point(xy);
      if (p.yarn == YarnType::gap) continue;
      const std::size_t at = (static_cast<std::size_t>(row) * texture_size + column) * 3;
      for (int c = 0; c < 3; ++c) {
        material.normal[at + c] = p.normal[c];
        material.orientation[at + c] = p.orientation[c];
      }
    }
  return material;
}

Result<std::vector<WovenQuery>> generate_woven_queries(const WeaveMatrix& weave,
                                                       const WovenMaterialParameters& parameters,
                                                       std::uint32_t material,
                                                       const WovenDatasetOptions& options,
                                                       std::uint64_t seed) {
  if (options.centre_grid <= 0 || options.small_sizes < 0 || options.large_sizes < 0 ||
      options.small_sizes + options.large_sizes == 0 || options.direction_grid <= 0 ||
      options.samples <= 0 || !(options.max_size >= 1))
    return std::unexpected(bad_input({}, "options", "a data set option is out of range"));
  auto surface = WovenSurface::make(weave, parameters.shape, parameters.beta, parameters.beta);
  if (!surface) return std::unexpected(surface.error());
  const WovenShading shading{parameters.alpha, parameters.alpha, kDefaultDiffuseBlend};
  const int sizes = options.small_sizes + options.large_sizes;
  const int footprints = options.centre_grid * options.centre_grid * sizes;
  std::vector<std::vector<WovenQuery>> per_footprint(static_cast<std::size_t>(footprints));

  parallel_chunks(footprints, 1, [&](int begin, int end) {
    for (int index = begin; index < end; ++index) {
      const int centre = index / sizes, size_index = index % sizes;
      // The centre's jitter is shared by its sizes: one centre, 20 sizes.
      SampleRandom centre_random(mix_seed(seed, mix_seed(kCentreKey, mix_seed(material, centre))));
      const int cx = centre % options.centre_grid, cy = centre / options.centre_grid;
      const float u = (cx + centre_random.uniform()) / options.centre_grid;
      const float v = (cy + centre_random.uniform()) / options.centre_grid;
      SampleRandom random(mix_seed(seed, mix_seed(kFootprintKey, mix_seed(material, index))));
      const float size = footprint_size(size_index, options.small_sizes, options.large_sizes,
                                        options.max_size, random.uniform());
      const FootprintSamples samples = sample_footprint(
          *surface, footprint_in_repeats(*surface, u, v, size), options.samples, random.next());
      const auto incoming =
          stratified_directions(options.direction_grid, options.min_cosine, random);
      const auto outgoing =
          stratified_directions(options.direction_grid, options.min_cosine, random);
      const std::vector<WovenComponents> answers =
          aggregate_direction_pairs(*surface, samples, incoming, outgoing, shading);
      std::vector<WovenQuery>& queries = per_footprint[static_cast<std::size_t>(index)];
      queries.reserve(answers.size());
      for (std::size_t i = 0; i < incoming.size(); ++i)
        for (std::size_t o = 0; o < outgoing.size(); ++o) {
          const Eigen::Vector3f &wi = incoming[i], &wo = outgoing[o];
          const WovenComponents& c = answers[i * outgoing.size() + o];
          WovenQuery q;
          q.material = material;
          q.u = u;
          q.v = v;
          q.size = size;
          q.wi = {wi.x(), wi.y(), wi.z()};
          q.wo = {wo.x(), wo.y(), wo.z()};
          q.c_warp = c.c_warp;
          q.c_weft = c.c_weft;
          q.s_warp = c.s_warp;
          q.s_weft = c.s_weft;
          queries.push_back(q);
        }
    }
  });

  std::vector<WovenQuery> queries;
  std::size_t total = 0;
  for (const auto& part : per_footprint)
    total += part.size();
  queries.reserve(total);
  for (const auto& part : per_footprint)
    queries.insert(queries.end(), part.begin(), part.end());
  return queries;
}

Result<WovenDataset> generate_woven_dataset(const std::vector<WeaveMatrix>& patterns,
                                            const WovenDatasetOptions& options, std::uint64_t seed,
                                            const WovenDatasetProgress& progress) {
  const int total = static_cast<int>(patterns.size()) *
                    (options.shapes_per_pattern * options.appearances_per_shape +
                     (options.default_appearance ? 1 : 0));
  WovenDataset dataset;
  dataset.seed = seed;
  std::uint32_t material = 0;
  // One material into the data set: its textures and its queries.
  const auto add = [&](std::size_t pattern, const WovenMaterialParameters& parameters) -> Status {
    auto sample = generate_woven_material(patterns[pattern], parameters, options.texture_size);
    if (!sample) return std::unexpected(sample.error());
    auto queries = generate_woven_queries(patterns[pattern], parameters, material, options, seed);
    if (!queries) return std::unexpected(queries.error());
    dataset.materials.push_back(std::move(*sample));
    dataset.queries.insert(dataset.queries.end(), queries->begin(), queries->end());
    if (progress) progress(static_cast<int>(material) + 1, total);
    return {};
  };
  for (std::size_t pattern = 0; pattern < patterns.size(); ++pattern)
    for (int s = 0; s < options.shapes_per_pattern; ++s) {
      const YarnShape shape =
          draw_yarn_shape(mix_seed(seed, mix_seed(kShapeKey, mix_seed(pattern, s))));
      for (int a = 0; a < options.appearances_per_shape; ++a, ++material) {
        const WovenMaterialParameters drawn =
            draw_appearance(shape, mix_seed(seed, mix_seed(kAppearanceKey, material)));
        if (auto added = add(pattern, drawn); !added) return std::unexpected(added.error());
      }
    }
  if (options.default_appearance)
    for (std::size_t pattern = 0; pattern < patterns.size(); ++pattern, ++material)
      if (auto added = add(pattern, WovenMaterialParameters{}); !added)
        return std::unexpected(added.error());
  return dataset;
}

double expected_queries_per_material(const WovenDatasetOptions& options) {
  const double disc = std::numbers::pi / 4 * options.direction_grid * options.direction_grid;
  return static_cast<double>(options.centre_grid) * options.centre_grid *
         (options.small_sizes + options.large_sizes) * disc * disc;
}

}  // namespace psrig::cloth
