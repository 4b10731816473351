#pragma once
// `retimegs merge`: window models of one clip (train --window, model/window.hpp) stitched into one
// model of the range they cover together.
//
// The windows must share the clip's time grid and model settings and follow each other without
// gap or overlap, each starting at the training frame where the previous one ends (the seam). The
// merged model holds every window's primitives unchanged; since its window is the union, an edge
// ending at an interior seam is no longer at a clip end and is an ordinary closed sigmoid there
// (model/window.hpp), so the two sides meet at σ_τ = 0.5 each, as adjacent intervals do inside a
// window. Each training camera's colour map is the mean of the windows' maps weighted by their
// number of training intervals (each window fixed its own gauge, the average camera of its frames).
// The merged model records its seams (ModelConfig::seams), where eval --stability looks for jumps,
// and their fade (ModelConfig::seam_fade): an edge at a seam is a sigmoid of that scale instead of
// γ, so that one window's reconstruction of the static world cross-fades into the next's over a
// fraction of the training interval instead of jumping within a tenth of a frame.
#include <string>
#include <vector>

#include "retimegs/model/model_file.hpp"

namespace retimegs::model {

// merge --seam-fade's default, training intervals: chosen on bench/windows.sh (README "Long clips
// and Slurm").
constexpr double kDefaultSeamFade = 0.25;

// `names[k]` names `windows[k]` in errors (its file). Throws Error, in one line naming the files,
// for: no model, a SpacetimeGaussians model (its Gaussian windows have no edges to close), models
// with different time grids or model settings (representation, trajectory, γ, ε, SH degree), and
// windows that overlap or leave a gap. A model without a window covers its whole clip. The first
// window's training config is kept for provenance. `seam_fade` (training intervals, within
// core/limits.hpp's range; 0 keeps γ) applies to every seam, a merged model's own included.
Model merge_models(const std::vector<Model>& windows, const std::vector<std::string>& names,
                   double seam_fade = kDefaultSeamFade);

}  // namespace retimegs::model
