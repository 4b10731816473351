#pragma once
// `retimegs merge`: window models of one clip (train --window, model/window.hpp) stitched into one
// model of the range they cover together.
//
// The windows must share the clip's time grid and model settings and follow each other without a
// gap: each starts at or before the training frame where the previous one ends, and starts and
// ends after it (slurm --overlap). Consecutive windows hand over at a seam: the middle of the
// training frames both trained (their shared boundary frame where they only touch). The merged
// model holds each window's primitives between its seams: a primitive whose support lies beyond a
// seam is left out (the neighbour's reconstruction covers that time) and a support that crosses
// one ends there. An edge at an interior seam is no longer at a clip end and is an ordinary closed
// sigmoid (model/window.hpp), so the two sides meet at σ_τ = 0.5 each, as adjacent intervals do
// inside a window; its scale is the seam's fade (ModelConfig::seam_fade). Drawn (playback's
// ModelRenderer, the viewer), an image near a seam is the cross-fade of the two windows' images,
// each window drawn whole with its edges at the seam open (model::seam_handover): one window's
// reconstruction of the static world fades into the next's over a fraction of a training interval
// instead of jumping within a tenth of a frame, and stays whole while it does. The fade shows each
// side beyond the seam, so only what was trained there or stays put keeps it: a support the merge
// cut (trained on both sides), and an edge whose primitive moves less than half its largest axis
// over the fade's reach. A moving primitive's edge that ended at the seam in its own window (the
// interval before or after it) moves 2ε off the seam, out of the fade's reach, and keeps γ: a fade
// would show it on a path never trained, a faint ghost beside the seam. Each training camera's
// colour map is the mean of the windows' maps weighted by their number of training intervals (each
// window fixed its own gauge, the average camera of its frames), and its pose correction (issue 65)
// the same weighted mean of the windows' ω and of their τ. The merged model records its seams
// (ModelConfig::seams), where eval --stability looks for jumps.
#include <optional>
#include <string>
#include <vector>

#include "retimegs/model/model_file.hpp"

namespace retimegs::model {

// merge --seam-fade's default, training intervals: chosen on bench/windows.sh (README "Long clips
// and Slurm"). A wider fade spreads the static world's handover over more frames, but shows more
// of each window beyond its seam, where it was never trained, and from about three quarters of an
// interval on, moves the handover's change onto the neighbouring training frames.
constexpr double kDefaultSeamFade = 0.5;

// `names[k]` names `windows[k]` in errors (its file). Throws Error, in one line naming the files,
// for: no model, a SpacetimeGaussians model (its Gaussian windows have no edges to close), models
// with different time grids or model settings (representation, trajectory, γ, ε, SH degree), and
// windows that leave a gap or hold one another. A model without a window covers its whole clip. The
// first window's training config is kept for provenance. `seam_fade` (training intervals, within
// core/limits.hpp's range; 0 keeps γ) applies to every seam, a merged model's own included;
// without it, kDefaultSeamFade.
Model merge_models(const std::vector<Model>& windows, const std::vector<std::string>& names,
                   std::optional<double> seam_fade = std::nullopt);

}  // namespace retimegs::model
