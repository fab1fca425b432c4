#include "woven_training.h"

#include <chrono>
#include <cstdio>
#include <random>
#include <unistd.h>

#include "woven_model.h"

namespace psrig::train_woven {
namespace {

using Clock = std::chrono::steady_clock;
constexpr std::int64_t evaluation_queries = 8192;

// The data set as tensors, once: every material's encoder inputs and every
// query's decoder inputs, with each material's query rows.
struct TrainingData {
  const cloth::WovenDataset* dataset = nullptr;
  std::vector<cloth::WovenFootprintFeatures> features;  // a material's, for the quarters
  std::vector<torch::Tensor> textures, parameters;
  QueryTensors queries;
  std::vector<std::vector<std::int64_t>> rows_of_material;
  std::vector<std::size_t> materials_with_queries;
};

TrainingData training_data(const cloth::WovenDataset& dataset,
                           const cloth::WovenNetworkShape& shape) {
  TrainingData data;
  data.dataset = &dataset;
  for (const cloth::WovenMaterialSample& material : dataset.materials) {
    data.textures.push_back(material_textures(material));
    data.parameters.push_back(material_parameters(material));
  }
  data.features = footprint_feature_tables(dataset, shape);
  data.queries = query_tensors(dataset, shape, data.features);
  data.rows_of_material.resize(dataset.materials.size());
  for (std::size_t q = 0; q < dataset.queries.size(); ++q) {
    data.rows_of_material[dataset.queries[q].material].push_back(static_cast<std::int64_t>(q));
  }
  for (std::size_t m = 0; m < data.rows_of_material.size(); ++m) {
    if (!data.rows_of_material[m].empty()) data.materials_with_queries.push_back(m);
  }
  return data;
}

// The latents of the query rows `rows`, encoding each material they touch once.
torch::Tensor row_latents(WovenModel& model, const TrainingData& data, const torch::Tensor& rows) {
  const torch::Tensor materials = data.queries.materials.index_select(0, rows);
  const auto [unique, inverse] =
      torch::_unique(materials, /*sorted=*/true, /*return_inverse=*/true);
  std::vector<torch::Tensor> latents;
  const std::int64_t* ids = unique.data_ptr<std::int64_t>();
  for (std::int64_t i = 0; i < unique.numel(); ++i) {
    latents.push_back(model->encoder(data.textures[static_cast<std::size_t>(ids[i])],
                                     data.parameters[static_cast<std::size_t>(ids[i])]));
  }
  return torch::cat(latents, 0).index_select(0, inverse);
}

// The decoder's predictions for the query rows `rows`, given their latents.
torch::Tensor predict(WovenModel& model, const TrainingData& data, const torch::Tensor& rows,
                      const torch::Tensor& latents) {
  return model->decoder(latents, data.queries.footprints.index_select(0, rows),
                        data.queries.angular.index_select(0, rows));
}

// The components (C, and S with g inverted) from the network's outputs.
torch::Tensor components_of(const torch::Tensor& outputs) {
  const torch::Tensor diffuse = outputs.slice(1, 0, 2);
  const torch::Tensor specular =
      torch::clamp_min((torch::exp(outputs.slice(1, 2, 4)) - 1) / cloth::woven_specular_k, 0);
  return torch::cat({diffuse, specular}, 1);
}

// TrainingOptions::consistency's term for the rows (their latents and
// outputs given): eq. 11's form between the rows' outputs and the mean of
// their quarters' (each half the size, about the rows' centre moved a
// quarter of the size each way), g applied.
torch::Tensor consistency_loss(WovenModel& model, const TrainingData& data,
                               const torch::Tensor& rows, const torch::Tensor& latents_of_rows,
                               const torch::Tensor& outputs, double diffuse) {
  const cloth::WovenNetworkShape& shape = model->shape;
  const int inputs = cloth::decoder_footprint_inputs(shape);
  const std::int64_t count = rows.numel();
  torch::Tensor quarters = torch::empty({count * 4, inputs});
  float* out = quarters.data_ptr<float>();
  const std::int64_t* row = rows.data_ptr<std::int64_t>();
  for (std::int64_t r = 0; r < count; ++r) {
    const cloth::WovenQuery& q = data.dataset->queries[static_cast<std::size_t>(row[r])];
    for (int k = 0; k < 4; ++k) {
      const float du = (k % 2 == 0 ? -0.25F : 0.25F) * q.size;
      const float dv = (k / 2 == 0 ? -0.25F : 0.25F) * q.size;
      cloth::woven_footprint_inputs(
          shape, data.features[q.material], q.u + du, q.v + dv, q.size / 2,
          std::span(out + (r * 4 + k) * inputs, static_cast<std::size_t>(inputs)));
    }
  }
  const torch::Tensor latents = latents_of_rows.repeat_interleave(4, 0);
  const torch::Tensor angular = data.queries.angular.index_select(0, rows).repeat_interleave(4, 0);
  const torch::Tensor mean =
      components_of(model->decoder(latents, quarters, angular)).view({count, 4, 4}).mean(1);
  const torch::Tensor target = torch::cat(
      {mean.slice(1, 0, 2), torch::log(cloth::woven_specular_k * mean.slice(1, 2, 4) + 1)}, 1);
  return woven_loss(outputs, target, diffuse);
}

// A fixed spread of up to evaluation_queries rows.
torch::Tensor evaluation_rows(const TrainingData& data) {
  const std::int64_t count = data.queries.targets.size(0);
  const std::int64_t take = std::min(count, evaluation_queries);
  return torch::div(torch::arange(take, torch::kInt64) * count, std::max<std::int64_t>(take, 1),
                    "floor");
}

double evaluate(WovenModel& model, const TrainingData& data, const torch::Tensor& rows) {
  torch::NoGradGuard no_grad;
  double total = 0;
  const std::int64_t chunk = 2048;
  for (std::int64_t start = 0; start < rows.numel(); start += chunk) {
    const torch::Tensor part = rows.slice(0, start, std::min(rows.numel(), start + chunk));
    const torch::Tensor outputs = predict(model, data, part, row_latents(model, data, part));
    total += woven_loss(outputs, data.queries.targets.index_select(0, part)).item<double>() *
             static_cast<double>(part.numel());
  }
  return total / static_cast<double>(std::max<std::int64_t>(rows.numel(), 1));
}

// A step's batch from (seed, step) alone, so a resumed run draws the same.
torch::Tensor batch_rows(const TrainingData& data, const TrainingOptions& options,
                         std::int64_t step) {
  std::seed_seq seeds{static_cast<std::uint32_t>(options.seed),
                      static_cast<std::uint32_t>(options.seed >> 32),
                      static_cast<std::uint32_t>(step), static_cast<std::uint32_t>(step >> 32)};
  std::mt19937_64 random(seeds);
  const auto& candidates = data.materials_with_queries;
  std::uniform_int_distribution<std::size_t> pick_material(0, candidates.size() - 1);
  std::vector<std::int64_t> rows;
  rows.reserve(static_cast<std::size_t>(options.batch));
  const int per_material = std::max(1, options.batch / std::max(1, options.materials_per_step));
  while (static_cast<int>(rows.size()) < options.batch) {
    const auto& material_rows = data.rows_of_material[candidates[pick_material(random)]];
    std::uniform_int_distribution<std::size_t> pick_row(0, material_rows.size() - 1);
    for (int i = 0; i < per_material && static_cast<int>(rows.size()) < options.batch; ++i) {
      rows.push_back(material_rows[pick_row(random)]);
    }
  }
  return torch::tensor(rows, torch::kInt64);
}

double learning_rate_at(const TrainingOptions& options, std::int64_t step) {
  double rate = options.learning_rate;
  if (step >= options.steps * 6 / 10) rate *= 0.2;
  if (step >= options.steps * 9 / 10) rate *= 0.2;
  return rate;
}

std::string duration_text(double seconds) {
  const auto s = static_cast<long>(seconds);
  char text[32];
  if (s >= 3600) {
    std::snprintf(text, sizeof text, "%ldh%02ldm", s / 3600, (s / 60) % 60);
  } else {
    std::snprintf(text, sizeof text, "%ldm%02lds", s / 60, s % 60);
  }
  return text;
}

// "[#####.....] step 1200/20000  loss 0.01234  1m20s, ETA 20m05s" on
// stderr: redrawn in place on a terminal, a line every 5 % otherwise.
class ProgressBar {
 public:
  ProgressBar(std::int64_t first, std::int64_t last, bool shown)
      : first_(first), last_(last), shown_(shown), terminal_(isatty(STDERR_FILENO) != 0) {}

  // Ends the bar's line on a terminal (the last step is always drawn).
  void finish() {
    if (shown_ && terminal_) std::fputc('\n', stderr);
  }

  void update(std::int64_t step, double loss) {
    if (!shown_) return;
    const bool final = step == last_;
    const auto now = Clock::now();
    const std::int64_t every = std::max<std::int64_t>(1, (last_ - first_) / 20);
    if (!final && (terminal_ ? now - drawn_ < std::chrono::milliseconds(250)
                             : (step - first_) % every != 0)) {
      return;
    }
    drawn_ = now;
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    const double done = static_cast<double>(step - first_);
    const double eta = done > 0 ? elapsed / done * static_cast<double>(last_ - step) : 0;
    const int filled = last_ > 0 ? static_cast<int>(30 * step / last_) : 30;
    std::fprintf(stderr, "%s[%-30s] step %lld/%lld  loss %.5f  %s, ETA %s%s", terminal_ ? "\r" : "",
                 std::string(static_cast<std::size_t>(filled), '#').c_str(),
                 static_cast<long long>(step), static_cast<long long>(last_), loss,
                 duration_text(elapsed).c_str(), duration_text(eta).c_str(), terminal_ ? "" : "\n");
    std::fflush(stderr);
  }

 private:
  std::int64_t first_, last_;
  bool shown_, terminal_;
  Clock::time_point start_ = Clock::now(), drawn_{};
};

Status save_checkpoint(const std::filesystem::path& file, WovenModel& model,
                       torch::optim::Adam& optimizer, std::int64_t step) {
  std::filesystem::path temporary = file;
  temporary += ".tmp";
  try {
    torch::serialize::OutputArchive archive, model_archive, optimizer_archive;
    model->save(model_archive);
    optimizer.save(optimizer_archive);
    archive.write("model", model_archive);
    archive.write("optimizer", optimizer_archive);
    archive.write("step", torch::tensor(step, torch::kInt64));
    archive.save_to(temporary.string());
  } catch (const c10::Error& error) {
    return std::unexpected(io_error(
        temporary, std::string("cannot write the checkpoint: ") + error.what_without_backtrace()));
  }
  std::error_code failed;
  std::filesystem::rename(temporary, file, failed);
  if (failed) {
    return std::unexpected(
        io_error(file, "cannot rename the checkpoint into place: " + failed.message()));
  }
  return {};
}

Result<std::int64_t> load_checkpoint(const std::filesystem::path& file, WovenModel& model,
                                     torch::optim::Adam& optimizer) {
  try {
    torch::serialize::InputArchive archive, model_archive, optimizer_archive;
    archive.load_from(file.string());
    archive.read("model", model_archive);
    model->load(model_archive);
    archive.read("optimizer", optimizer_archive);
    optimizer.load(optimizer_archive);
    torch::Tensor step;
    archive.read("step", step);
    return step.item<std::int64_t>();
  } catch (const c10::Error& error) {
    return std::unexpected(
        bad_input(file, "--resume",
                  std::string("not a checkpoint of this network (another shape?): ") +
                      error.what_without_backtrace()));
  }
}

// The training; the caller turns libtorch's exceptions into errors.
Result<TrainingResult> train(const cloth::WovenDataset& dataset, const TrainingOptions& options,
                             const std::string& command) {
  if (dataset.queries.empty()) {
    return std::unexpected(bad_input({}, "", "the data set holds no queries"));
  }
  if (auto ok = cloth::random_woven_network(options.shape, 0); !ok) {
    return std::unexpected(ok.error());  // a shape the runtime would refuse
  }
  torch::set_num_threads(options.threads);
  torch::manual_seed(options.seed);
  WovenModel model(options.shape);
  torch::optim::Adam optimizer(
      model->parameters(),
      torch::optim::AdamOptions(options.learning_rate).weight_decay(options.weight_decay));
  const TrainingData data = training_data(dataset, options.shape);
  const torch::Tensor evaluation = evaluation_rows(data);

  TrainingResult result;
  result.initial_loss = evaluate(model, data, evaluation);
  std::int64_t step = 0;
  if (options.resume && !options.checkpoint.empty() &&
      std::filesystem::exists(options.checkpoint)) {
    auto resumed = load_checkpoint(options.checkpoint, model, optimizer);
    if (!resumed) {
      return std::unexpected(resumed.error());
    }
    step = result.resumed_at = *resumed;
  }

  const std::int64_t last =
      options.stop_at > 0 ? std::min(options.stop_at, options.steps) : options.steps;
  ProgressBar bar(step, last, options.progress);
  double running = result.initial_loss;
  for (; step < last; ++step) {
    for (auto& group : optimizer.param_groups()) {
      static_cast<torch::optim::AdamOptions&>(group.options()).lr(learning_rate_at(options, step));
    }
    const torch::Tensor rows = batch_rows(data, options, step);
    optimizer.zero_grad();
    // Encoded once a step, for the rows and (the consistency term) their quarters.
    const torch::Tensor latents = row_latents(model, data, rows);
    const torch::Tensor outputs = predict(model, data, rows, latents);
    const double diffuse = options.diffuse_loss_weight;
    torch::Tensor loss = woven_loss(outputs, data.queries.targets.index_select(0, rows), diffuse);
    if (options.consistency > 0) {
      // On the batch's first quarter of rows, a quarter of the term's cost.
      // batch_rows draws a material's rows together, so that is one of the
      // step's materials: every material over the steps, the same
      // expectation, more variance (the shipped weights were trained so).
      const std::int64_t held = std::max<std::int64_t>(1, rows.numel() / 4);
      loss = loss + options.consistency * consistency_loss(model, data, rows.slice(0, 0, held),
                                                           latents.slice(0, 0, held),
                                                           outputs.slice(0, 0, held), diffuse);
    }
    loss.backward();
    optimizer.step();
    running = 0.98 * running + 0.02 * loss.item<double>();
    bar.update(step + 1, running);
    const bool checkpoint_due = (step + 1) % options.checkpoint_every == 0 || step + 1 == last;
    if (!options.checkpoint.empty() && checkpoint_due) {
      if (auto saved = save_checkpoint(options.checkpoint, model, optimizer, step + 1); !saved) {
        return std::unexpected(saved.error());
      }
    }
  }
  result.final_loss = evaluate(model, data, evaluation);
  bar.finish();

  result.weights = to_weights(model);
  result.weights.command = command;
  result.weights.seed = options.seed;
  result.weights.steps = static_cast<std::uint64_t>(last);
  result.weights.final_loss = static_cast<float>(result.final_loss);
  return result;
}

}  // namespace

Result<TrainingResult> train_woven_network(const cloth::WovenDataset& dataset,
                                           const TrainingOptions& options,
                                           const std::string& command) {
  try {
    return train(dataset, options, command);
  } catch (const c10::Error& error) {
    return std::unexpected(
        internal_error(std::string("libtorch: ") + error.what_without_backtrace()));
  }
}

}  // namespace psrig::train_woven
