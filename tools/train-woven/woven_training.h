#pragma once
// Training the neural woven BSDF on a data set (chen2024 5.2, sized for a
// CPU): each step picks a few materials, encodes them, and decodes a
// batch of their queries; Adam with weight decay; the learning rate falls
// by 0.2 at 60 % and 90 % of the steps (the paper's sixth and ninth of ten
// epochs). A checkpoint every N steps resumes to the same weights as an
// unbroken run: a step's batch comes from (seed, step) alone.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include "psrig/base/error.h"
#include "psrig/cloth/woven_dataset.h"
#include "psrig/cloth/woven_network_weights.h"

namespace psrig::train_woven {

struct TrainingOptions {
  cloth::WovenNetworkShape shape;
  std::int64_t steps = 20000;
  std::int64_t stop_at = 0;    // stop after this step (0: at `steps`), resumable later
  int batch = 512;             // queries a step (the paper's 512)
  int materials_per_step = 4;  // materials a batch draws from
  double learning_rate = 1e-3;
  double weight_decay = 1e-6;  // the paper's "regularization to all the weights"
  std::uint64_t seed = 1;
  int threads = 1;                   // torch's intra-op threads; 1 is bit-reproducible
  std::filesystem::path checkpoint;  // empty: none
  std::int64_t checkpoint_every = 500;
  bool resume = false;   // continue from `checkpoint` if it exists
  bool progress = true;  // the bar on stderr
  // The weight of the consistency term (0: none, the paper's loss alone): a
  // footprint's answer held to the mean of its four quarters' (in C and in
  // S, before g), as the box-filtered aggregate nearly is. A decoder that
  // keeps it gives a frame whose mean does not move with the pixel grid's
  // phase over the pattern (the far level's dolly). Taken on the first
  // quarter of each batch's rows (one of its materials).
  double consistency = 0;
  // Eq. 11's lambda_C in training (the evaluation losses keep the paper's
  // 0.1). With the paper's, a C 30 % off weighs some 30 times less than S
  // 10 % off (C is linear, about 0.05 to 0.15; S is g'd, about 1), so the
  // diffuse components, most of a woven's colour, are left loosely fitted.
  double diffuse_loss_weight = 0.1;  // woven_model.h's diffuse_weight
};

struct TrainingResult {
  cloth::WovenNetworkWeights weights;  // command, seed, steps, final loss filled in
  double initial_loss = 0;             // eq. 11 over the evaluation queries, before the first step
  double final_loss = 0;               // and after the last
  std::int64_t resumed_at = 0;         // the step the run started from (0: from scratch)
};

// Trains from scratch or from the checkpoint; the losses are measured over
// up to 8192 of the data set's queries, the same every time.
[[nodiscard]] Result<TrainingResult> train_woven_network(const cloth::WovenDataset& dataset,
                                                         const TrainingOptions& options,
                                                         const std::string& command);

}  // namespace psrig::train_woven
