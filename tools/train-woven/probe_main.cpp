// psrig-woven-probe: how a trained neural woven BSDF (psrig-woven-net/1 or /2)
// answers against fresh Monte-Carlo aggregates, by footprint size: on a
// grid of footprint centres, for a light and eyes given (the far-view
// test's by default), the sum of the four
// components (f with every k = 1) of the decoder against the aggregate's:
// their means, their spatial standard deviations (the pattern's contrast),
// correlation and RMSE. For each .weave file given, at the far level's
// parameters (alpha 0.5, beta 1, the default yarn shape: preview's
// woven_far_material), or a data set's materials at their own. Links
// psrig_cloth only; tools/train-woven/README.md says how.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <numbers>
#include <sstream>

#include <CLI/CLI.hpp>

#include "psrig/base/cli_command.h"
#include "psrig/base/parallel.h"
#include "psrig/cloth/weave_matrix.h"
#include "psrig/cloth/weave_rules.h"
#include "psrig/cloth/woven_aggregate.h"
#include "psrig/cloth/woven_bsdf.h"
#include "psrig/cloth/woven_dataset_generator.h"
#include "psrig/cloth/woven_network.h"

namespace {

using namespace psrig;

// A direction (unit, +z the cloth's front) from its tilt off the normal
// and its azimuth from the weft (x), in degrees.
Eigen::Vector3f direction(float tilt_deg, float azimuth_deg) {
  const float t = tilt_deg * std::numbers::pi_v<float> / 180;
  const float a = azimuth_deg * std::numbers::pi_v<float> / 180;
  return {std::sin(t) * std::cos(a), std::sin(t) * std::sin(a), std::cos(t)};
}

// "TILT,AZIMUTH" in degrees, tilt below 90.
bool parse_direction(const std::string& text, Eigen::Vector3f& out) {
  float tilt = 0, azimuth = 0;
  char comma = 0;
  std::istringstream in(text);
  if (!(in >> tilt >> comma >> azimuth) || comma != ',' || !(in >> std::ws).eof() ||
      !(tilt >= 0 && tilt < 90)) {
    return false;
  }
  out = direction(tilt, azimuth);
  return true;
}

double f_of(const cloth::WovenComponents& c) { return c.c_warp + c.c_weft + c.s_warp + c.s_weft; }

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("Probes a neural woven BSDF against fresh aggregates, by footprint size",
               "psrig-woven-probe");
  std::vector<std::filesystem::path> weights_files, weave_files;
  int grid = 12, samples = 4096;
  app.add_option("weaves", weave_files, ".weave files")->required();
  app.add_option("--weights", weights_files, "psrig-woven-net/1 or /2 files")->required();
  app.add_option("--centre-grid", grid)->capture_default_str();
  app.add_option("--samples", samples)->capture_default_str();
  // The defaults: the far-view test's light (45 degrees), the eye head on
  // and obliquely; footprints 0.1 to 1.5 repeats wide.
  std::vector<float> sizes = {0.1F, 0.2F, 0.3F, 0.45F, 0.7F, 1.5F};
  std::string light_text = "45,45";
  std::vector<std::string> eye_texts = {"0,0", "34.75,-52.1"};
  app.add_option("--sizes", sizes, "footprint widths in repeats")->capture_default_str();
  app.add_option("--light", light_text,
                 "the light's TILT,AZIMUTH in degrees (azimuth from the weft)")
      ->capture_default_str();
  app.add_option("--eye", eye_texts, "each eye's TILT,AZIMUTH in degrees")->capture_default_str();
  std::filesystem::path dataset_file;
  std::vector<int> dataset_materials;
  app.add_option("--dataset", dataset_file,
                 "a data set whose --material entries (chen2024's weaves or the weaves given) "
                 "to probe at their own parameters instead of the far level's");
  app.add_option("--material", dataset_materials, "material indices of --dataset");
  CLI11_PARSE(app, argc, argv);
  set_thread_count(0);
  std::vector<Eigen::Vector3f> incoming(1), outgoing(eye_texts.size());
  bool directions_ok = parse_direction(light_text, incoming[0]);
  for (std::size_t e = 0; e < eye_texts.size(); ++e)
    directions_ok = directions_ok && parse_direction(eye_texts[e], outgoing[e]);
  if (!directions_ok || sizes.empty() ||
      !std::all_of(sizes.begin(), sizes.end(), [](float s) { return s > 0 && s <= 10; })) {
    std::fprintf(stderr,
                 "psrig-woven-probe: error: --light and --eye take TILT,AZIMUTH in degrees "
                 "(tilt 0 to 90), --sizes widths in (0, 10] repeats\n");
    return 2;
  }
  // An eye's label: "head-on", or its tilt and azimuth.
  const auto eye_label = [&](std::size_t e) {
    return std::abs(outgoing[e].z() - 1) < 1e-6F ? std::string("head-on") : "eye " + eye_texts[e];
  };

  std::vector<cloth::WovenNetwork> networks;
  for (const auto& file : weights_files) {
    auto network = cloth::WovenNetwork::load(file);
    if (!network) {
      std::fprintf(stderr, "psrig-woven-probe: error: %s\n", network.error().describe().c_str());
      return exit_code(network.error());
    }
    networks.push_back(std::move(*network));
  }
  // What to probe: each weave at the far level's parameters, or the data
  // set's materials at theirs.
  std::vector<std::pair<cloth::WeaveMatrix, cloth::WovenMaterialParameters>> cases;
  std::vector<cloth::WeaveMatrix> weaves = cloth::chen2024_training_weaves();
  for (const auto& weave_file : weave_files) {
    auto weave = cloth::load_weave_matrix(weave_file);
    if (!weave) {
      std::fprintf(stderr, "psrig-woven-probe: error: %s\n", weave.error().describe().c_str());
      return exit_code(weave.error());
    }
    if (dataset_file.empty()) {  // as the far level encodes it (woven_far_material)
      cases.emplace_back(*weave, cloth::weave_parameters(*weave));
    }
    weaves.push_back(std::move(*weave));
  }
  if (!dataset_file.empty()) {
    auto dataset = cloth::read_woven_dataset(dataset_file);
    if (!dataset) {
      std::fprintf(stderr, "psrig-woven-probe: error: %s\n", dataset.error().describe().c_str());
      return exit_code(dataset.error());
    }
    for (int m : dataset_materials) {
      if (m < 0 || static_cast<std::size_t>(m) >= dataset->materials.size()) {
        std::fprintf(stderr, "psrig-woven-probe: error: %s has %zu materials, no material %d\n",
                     dataset_file.c_str(), dataset->materials.size(), m);
        return 2;
      }
      const cloth::WovenMaterialSample& record = dataset->materials.at(static_cast<std::size_t>(m));
      cloth::WovenMaterialParameters parameters;
      parameters.shape.twist_deg = record.twist_deg;
      parameters.shape.inclination_deg = record.inclination_deg;
      parameters.alpha = record.roughness;
      parameters.beta = record.height_scale;
      for (const auto& weave : weaves)
        if (weave.name == record.pattern) {
          cases.emplace_back(weave, parameters);
          break;
        }
      std::printf("material %d: %s twist %.0f inclination %.1f alpha %.3f beta %.3f\n", m,
                  record.pattern.c_str(), record.twist_deg, record.inclination_deg,
                  record.roughness, record.height_scale);
    }
  }
  const int pairs = static_cast<int>(incoming.size() * outgoing.size());
  for (const auto& [weave_matrix, parameters] : cases) {
    const cloth::WeaveMatrix* weave = &weave_matrix;
    const cloth::WovenShading shading{parameters.alpha, parameters.alpha,
                                      cloth::kDefaultDiffuseBlend};
    auto surface = cloth::WovenSurface::make(*weave, parameters.shape, parameters.beta,
                                             parameters.beta);
    auto sample = cloth::generate_woven_material(*weave, parameters, 64);
    for (const Status& made : {surface ? Status{} : Status(std::unexpected(surface.error())),
                               sample ? Status{} : Status(std::unexpected(sample.error()))})
      if (!made) {
        std::fprintf(stderr, "psrig-woven-probe: error: %s\n", made.error().describe().c_str());
        return exit_code(made.error());
      }
    // truth[size][centre][pair]
    const int size_count = static_cast<int>(sizes.size()), centres = grid * grid;
    std::vector<cloth::WovenComponents> truth(
        static_cast<std::size_t>(size_count * centres * pairs));
    parallel_chunks(size_count * centres, 1, [&](int begin, int end) {
      for (int index = begin; index < end; ++index) {
        const int s = index / centres, c = index % centres;
        const float u = (static_cast<float>(c % grid) + 0.5F) / static_cast<float>(grid);
        const float v = (static_cast<float>(c / grid) + 0.5F) / static_cast<float>(grid);
        const auto points = cloth::sample_footprint(
            *surface,
            cloth::footprint_in_repeats(*surface, u, v, sizes[static_cast<std::size_t>(s)]),
            samples, static_cast<std::uint64_t>(index) + 1);
        const auto answers =
            cloth::aggregate_direction_pairs(*surface, points, incoming, outgoing, shading);
        std::copy(answers.begin(), answers.end(),
                  truth.begin() + static_cast<std::ptrdiff_t>(index) * pairs);
      }
    });
    for (std::size_t n = 0; n < networks.size(); ++n) {
      const cloth::WovenNetwork& network = networks[n];
      auto prepared = network.prepare(*sample);
      if (!prepared) {
        std::fprintf(stderr, "psrig-woven-probe: error: %s\n", prepared.error().describe().c_str());
        return exit_code(prepared.error());
      }
      const cloth::WovenDecoderMaterial& material = *prepared;
      std::printf("%s (alpha %.2f beta %.2f)  %s  (f = sum of the four components; over %d x %d centres)\n",
                  weave->name.c_str(), parameters.alpha, parameters.beta, weights_files[n].c_str(), grid, grid);
      std::printf(
          "  size  eye               mean net/truth  spatial std truth  net   ratio  corr  "
          "rmse/std\n");
      for (int s = 0; s < size_count; ++s)
        for (int p = 0; p < pairs; ++p) {
          std::vector<double> t, g;
          for (int c = 0; c < centres; ++c) {
            const float u = (static_cast<float>(c % grid) + 0.5F) / static_cast<float>(grid);
            const float v = (static_cast<float>(c / grid) + 0.5F) / static_cast<float>(grid);
            const auto& wi = incoming[static_cast<std::size_t>(p) / outgoing.size()];
            const auto& wo = outgoing[static_cast<std::size_t>(p) % outgoing.size()];
            cloth::WovenLookup lookup{u,
                                      v,
                                      sizes[static_cast<std::size_t>(s)],
                                      {wi.x(), wi.y(), wi.z()},
                                      {wo.x(), wo.y(), wo.z()}};
            g.push_back(f_of(network.decode(material, lookup)));
            t.push_back(f_of(truth[static_cast<std::size_t>((s * centres + c) * pairs + p)]));
          }
          const auto m = static_cast<double>(centres);
          double mt = 0, mn = 0;
          for (int c = 0; c < centres; ++c) {
            mt += t[c];
            mn += g[c];
          }
          mt /= m;
          mn /= m;
          double vt = 0, vn = 0, cv = 0, se = 0;
          for (int c = 0; c < centres; ++c) {
            vt += (t[c] - mt) * (t[c] - mt);
            vn += (g[c] - mn) * (g[c] - mn);
            cv += (t[c] - mt) * (g[c] - mn);
            se += (t[c] - g[c]) * (t[c] - g[c]);
          }
          const double st = std::sqrt(vt / m), sn = std::sqrt(vn / m);
          std::printf("  %4.2f  %-16s  %14.3f  %17.4f  %6.4f  %5.2f  %4.2f  %5.2f\n",
                      sizes[static_cast<std::size_t>(s)],
                      eye_label(static_cast<std::size_t>(p) % outgoing.size()).c_str(), mn / mt, st,
                      sn, sn / std::max(st, 1e-9), cv / std::sqrt(std::max(vt * vn, 1e-18)),
                      std::sqrt(se / m) / std::max(st, 1e-9));
        }
    }
  }
  return 0;
}
