// psrig-woven-dataset: the neural woven BSDF's training data set (chen2024
// 5.1, Table 2) from the fabric surface model, written as
// psrig-woven-dataset/1 for psrig-train-woven. chen2024's seven training
// weaves and any --weave files: the unseen ones (3/1 twill, 2/2 basket) stay out. Needs no
// libtorch. README.md beside it says how.

#include <chrono>
#include <cstdio>

#include <CLI/CLI.hpp>

#include "psrig/base/cli_command.h"
#include "psrig/base/parallel.h"
#include "psrig/cloth/weave_matrix.h"
#include "psrig/cloth/weave_rules.h"
#include "psrig/cloth/woven_dataset.h"
#include "psrig/cloth/woven_dataset_generator.h"

namespace {

std::string generator_command_line(int argc, char** argv) {
  std::string line = "psrig-woven-dataset";
  for (int i = 1; i < argc; ++i) {
    line += ' ';
    line += argv[i];
  }
  return line;
}

std::string minutes_seconds(double seconds) {
  const int whole = static_cast<int>(seconds + 0.5);
  return std::to_string(whole / 60) + "m" + (whole % 60 < 10 ? "0" : "") +
         std::to_string(whole % 60) + "s";
}

}  // namespace

int main(int argc, char** argv) {
  using namespace psrig;
  CLI::App app("Generates the neural woven BSDF's training data set (psrig-woven-dataset/1)",
               "psrig-woven-dataset");
  std::filesystem::path out;
  cloth::WovenDatasetOptions options;
  options.direction_grid = 4;
  std::uint64_t seed = 1;
  int threads = 0;
  bool quiet = false;
  app.add_option("-o,--out", out, "the data set to write (whole or not at all)")->required();
  app.add_option("--shapes", options.shapes_per_pattern, "yarn shapes (psi, u) a weave")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  app.add_option("--appearances", options.appearances_per_shape, "(alpha, beta) draws a shape")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  app.add_option("--direction-grid", options.direction_grid,
                 "wi and wo each stratified on G x G (chen2024: 8)")
      ->capture_default_str()
      ->check(CLI::Range(1, 16));
  app.add_option("--centre-grid", options.centre_grid, "footprint centres on N x N")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  app.add_option("--small-sizes", options.small_sizes, "footprint sizes in [0, 1] repeats a centre")
      ->capture_default_str()
      ->check(CLI::Range(0, 64));
  app.add_option("--large-sizes", options.large_sizes, "footprint sizes in [1, 5] repeats a centre")
      ->capture_default_str()
      ->check(CLI::Range(0, 64));
  std::vector<std::filesystem::path> extra_weaves;
  app.add_option("--weave", extra_weaves,
                 "a .weave file to train on besides chen2024's seven (repeatable; never the "
                 "unseen 3/1 twill or 2/2 basket)")
      ->check(CLI::ExistingFile);
  app.add_flag("--default-appearance", options.default_appearance,
               "and one material a weave at the far level's parameters (alpha 0.5, beta 1, "
               "the default yarn shape)");
  app.add_option("--samples", options.samples, "Monte Carlo samples a footprint")
      ->capture_default_str()
      ->check(CLI::Range(1, 1 << 20));
  app.add_option("--texture-size", options.texture_size, "texels a side of a material's repeat")
      ->capture_default_str()
      ->check(CLI::Range(2, 1024));
  app.add_option("--seed", seed, "every draw's seed")->capture_default_str();
  app.add_option("--threads", threads, "threads (0: one per core; the bytes do not depend on it)")
      ->capture_default_str()
      ->check(cli::thread_count());
  app.add_flag("-q,--quiet", quiet, "no progress");
  CLI11_PARSE(app, argc, argv);
  set_thread_count(threads);

  auto weaves = cloth::chen2024_training_weaves();
  for (const auto& file : extra_weaves) {
    auto weave = cloth::load_weave_matrix(file);
    if (!weave) {
      std::fprintf(stderr, "psrig-woven-dataset: error: %s\n", weave.error().describe().c_str());
      return exit_code(weave.error());
    }
    weaves.push_back(std::move(*weave));
  }
  const int materials =
      static_cast<int>(weaves.size()) *
      (options.shapes_per_pattern * options.appearances_per_shape + (options.default_appearance ? 1 : 0));
  if (!quiet)
    std::fprintf(stderr, "%zu weaves, %d materials, about %.2f M queries\n", weaves.size(),
                 materials, materials * cloth::expected_queries_per_material(options) / 1e6);
  const auto start = std::chrono::steady_clock::now();
  auto progress = [&](int done, int total) {
    if (quiet) return;
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::fprintf(stderr, "material %d/%d  %s, ETA %s\n", done, total,
                 minutes_seconds(elapsed).c_str(),
                 minutes_seconds(elapsed / done * (total - done)).c_str());
  };
  auto fail = [](const Error& error) {
    std::fprintf(stderr, "psrig-woven-dataset: error: %s\n", error.describe().c_str());
    return exit_code(error);
  };
  auto dataset = cloth::generate_woven_dataset(weaves, options, seed, progress);
  if (!dataset) return fail(dataset.error());
  dataset->command = generator_command_line(argc, argv);
  if (auto wrote = cloth::write_woven_dataset(out, *dataset); !wrote) return fail(wrote.error());
  if (!quiet)
    std::fprintf(
        stderr, "%zu materials, %zu queries in %s; wrote %s\n", dataset->materials.size(),
        dataset->queries.size(),
        minutes_seconds(
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count())
            .c_str(),
        out.c_str());
  return cli::exit_done;
}
