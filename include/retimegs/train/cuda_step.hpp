#pragma once
// The training step on an NVIDIA GPU (train/step.hpp; DESIGN.md §3 "A second device: CUDA"): the
// CPU step's method with every per-step array resident on the device — the primitives, their
// gradient and Adam moments, the training images in their 16-bit form, the step's renders and
// losses. Per step the host draws the view, uploads the camera's colour correction and the
// view's flows, and reads back a handful of numbers (the losses, the camera colour's gradient).
//
// Relocation, growth and dynamic stretching (McmcStrategy::reshape), due every few hundred steps,
// run on a host copy with the CPU's code, so that both devices reshape the model alike; the
// temporal index and its row order are rebuilt there too and the state uploaded again. The noise
// runs on the device every step, its key drawn from the host generator as the CPU draws it.
// Checkpoints and the final model are host copies (StepState): the same files as the CPU step's.
//
// Built only with the CUDA backend (RETIMEGS_HAS_CUDA); train/step.hpp's make_step chooses it.
#include <array>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "retimegs/train/config.hpp"
#include "retimegs/train/dataset.hpp"
#include "retimegs/train/step.hpp"

namespace retimegs::train {

std::unique_ptr<TrainingStep> make_cuda_step(const TrainingSet& set, const TrainConfig& config);

}  // namespace retimegs::train
