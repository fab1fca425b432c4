// psrig-train-woven: trains the neural woven BSDF (chen2024) on a
// psrig-woven-dataset/1 file and writes psrig-woven-net/1 (or /2) weights the
// runtime reads without libtorch. README.md beside it says how.

#include <cstdio>

#include <CLI/CLI.hpp>

#include "psrig/base/cli_command.h"
#include "psrig/cloth/woven_dataset.h"
#include "psrig/cloth/woven_network_weights.h"
#include "woven_training.h"

namespace {

std::string command_line(int argc, char** argv) {
  std::string line = "psrig-train-woven";
  for (int i = 1; i < argc; ++i) {
    line += ' ';
    line += argv[i];
  }
  return line;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace psrig;
  CLI::App app(
      "Trains the neural woven BSDF on a data set; writes its weights (psrig-woven-net/1, or /2 "
      "with footprint features)",
      "psrig-train-woven");
  std::filesystem::path dataset_file, weights_file;
  train_woven::TrainingOptions options;
  app.add_option("DATASET", dataset_file, "the data set (psrig-woven-dataset/1)")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("-o,--out", weights_file, "the weights to write (psrig-woven-net/1 or /2)")
      ->required();
  app.add_option("--steps", options.steps, "training steps (batches)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--batch", options.batch, "queries a step")
      ->capture_default_str()
      ->check(CLI::Range(1, 1 << 20));
  app.add_option("--materials-per-step", options.materials_per_step, "materials a batch draws from")
      ->capture_default_str()
      ->check(CLI::Range(1, 1024));
  app.add_option("--lr", options.learning_rate,
                 "Adam's learning rate (falls by 0.2 at 60 % and 90 %)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--weight-decay", options.weight_decay, "L2 regularisation of every weight")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--seed", options.seed, "the initial weights' and the batches' seed")
      ->capture_default_str();
  app.add_option("--threads", options.threads, "torch threads (1: the same weights on every run)")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));
  app.add_option("--checkpoint", options.checkpoint, "checkpoint file (default: OUT.checkpoint)");
  app.add_option("--checkpoint-every", options.checkpoint_every, "steps between checkpoints")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--stop-at", options.stop_at,
                 "stop after this step, keeping --steps' schedule (resume later)")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--resume", options.resume, "continue from the checkpoint when it exists");
  app.add_option("--fusion-width", options.shape.fusion_width,
                 "the spatial fusion's width (a multiple of 4)")
      ->capture_default_str();
  app.add_option("--angular-width", options.shape.angular_width,
                 "the angular decoder's width (a multiple of 4)")
      ->capture_default_str();
  app.add_option("--blob-bins", options.shape.blob_bins,
                 "one-blob bins for each of the footprint's u, v and size (3 x bins a multiple "
                 "of 4)")
      ->capture_default_str();
  app.add_option("--footprint-features", options.shape.footprint_features,
                 "the footprint's features beside its one-blob: 0 (the paper's decoder) or 12 "
                 "(the material's textures averaged over it, cloth/woven_footprint_features.h)")
      ->capture_default_str();
  app.add_option("--consistency", options.consistency,
                 "weight of the term holding a footprint's answer to its four quarters' mean "
                 "(0: the paper's loss alone)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--diffuse-weight", options.diffuse_loss_weight,
                 "eq. 11's lambda_C in training (the reported losses keep the paper's 0.1)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--latent", options.shape.latent_size, "the material latent's size")
      ->capture_default_str();
  app.add_option("--encoder-width", options.shape.encoder_width, "the encoder MLP's width")
      ->capture_default_str();
  bool quiet = false;
  app.add_flag("-q,--quiet", quiet, "no progress bar");
  CLI11_PARSE(app, argc, argv);
  options.progress = !quiet;
  if (options.checkpoint.empty()) {
    options.checkpoint = weights_file;
    options.checkpoint += ".checkpoint";
  }

  auto fail = [](const Error& error) {
    std::fprintf(stderr, "psrig-train-woven: error: %s\n", error.describe().c_str());
    return exit_code(error);
  };
  auto dataset = cloth::read_woven_dataset(dataset_file);
  if (!dataset) return fail(dataset.error());
  std::fprintf(stderr, "%zu materials, %zu queries (data set seed %llu)\n",
               dataset->materials.size(), dataset->queries.size(),
               static_cast<unsigned long long>(dataset->seed));
  auto trained = train_woven::train_woven_network(*dataset, options, command_line(argc, argv));
  if (!trained) return fail(trained.error());
  if (auto wrote = cloth::write_woven_network(weights_file, trained->weights); !wrote) {
    return fail(wrote.error());
  }
  std::fprintf(stderr, "evaluation loss %.5f -> %.5f%s; wrote %s\n", trained->initial_loss,
               trained->final_loss, trained->resumed_at > 0 ? " (resumed)" : "",
               weights_file.c_str());
  return cli::exit_done;
}
