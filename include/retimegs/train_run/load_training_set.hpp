#pragma once
// A scene's training set read from its files (train/dataset.hpp): the images and masks through
// media's codecs, the flows and points through io. Here rather than in train, so that train (the
// step and what it needs) builds without image codecs (the lean GPU build, DESIGN.md §3).
#include <optional>

#include "retimegs/io/scene.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/train/dataset.hpp"

namespace retimegs::train {

// Loads everything in parallel. Throws Error naming the file at fault (missing image, a flow of
// the wrong size, ...). Needs at least 2 training frames and 1 training camera.
// With a window, only the training frames within it (io::training_views with the window).
// With downscale F > 1 (train --downscale, gsplat's data_factor) the set is that scene at 1/F of
// its size, scaled here once: its cameras (downscaled()), images and masks (media::resize_area) and
// flows (media::resize_flow); the points stay. Throws Error naming --downscale unless F >= 1.
// Masks that `prepare --masks` estimated (io::Scene::estimated_masks_marker) are not read: they
// mark what moves, not the capture's foreground, and training treats the scene as one without
// masks (train/background.hpp).
TrainingSet load_training_set(const io::Scene& scene, io::FrameSelection which,
                              const std::optional<io::FrameWindow>& window = std::nullopt,
                              double downscale = 1.0);

}  // namespace retimegs::train
