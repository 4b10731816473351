#pragma once
// Window models: a long clip trained as time windows (train --window A:B) that share at least their
// boundary frames (slurm --overlap: a few training intervals), then merged (model/merge.hpp). A
// window model is stored with the whole clip's time grid and its window (Model::window), so that
// windows share one grid.
//
// Edges at a window's ends: while a window trains, nothing else covers the time beyond its ends,
// so they behave as clip ends (open edges, σ_τ ≡ 1 on that side), exactly as the clip's own ends
// do in a whole-clip run; a window model drawn alone (render, eval, export) behaves the same. In
// the merged model an interior seam is an ordinary training frame: the edges that end there (the
// merge ends every support that crosses it) are closed sigmoids again, each side at σ_τ = 0.5 at
// the seam, as two adjacent intervals meet in a whole-clip model, their scale the seam's fade
// (ModelConfig::seam_fade, model/merge.hpp). Each window's primitives at the seam were trained to
// explain the boundary frame on their own, as the compensated group renders of triple rendering
// train each group.
#include "retimegs/model/model_file.hpp"
#include "retimegs/model/primitives.hpp"

namespace retimegs::model {

// The grid of the window's training frames: clip.at(window.first), ..., clip.at(window.last).
TimeGrid window_grid(const TimeGrid& clip, const TimeWindow& window);

// The model settings a window trains with: `clip_config` with γ rescaled from the clip's length to
// the window's, so that an edge's sharpness in frames, γ (t_T − t_1), stays the clip's, and its
// seams (a partial merge) indexed on the window's grid.
ModelConfig window_config(const ModelConfig& clip_config, const TimeGrid& clip,
                          const TimeGrid& window);

// The model as it was trained and is drawn alone: its grid the window's (the window's ends are
// then the clip ends, open edges), γ rescaled so that an edge's sharpness in frames, γ (t_T − t_1),
// stays the clip's; the window is cleared. A model without a window is returned as it is.
Model window_view(const Model& model);

// The inverse: a model trained on `local.grid`, a run of the training frames of `clip`, with the
// clip's grid and model settings `clip_config` and its window recorded. Throws Error unless
// local.grid lies on `clip` with the same spacing. A window covering the whole clip is no window.
Model with_window(Model local, const TimeGrid& clip, const ModelConfig& clip_config);

}  // namespace retimegs::model
