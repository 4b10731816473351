#pragma once
// Approximate foreground masks for captures that have none (`retimegs prepare --masks`), from a
// background model of each static camera's own clip (OpenCV's MOG2 background subtractor),
// cleaned morphologically. (OpenCV's KNN subtractor counts a colour seen in two frames as
// background, which on a capture's short clips is most of what moves.) What moves during the clip
// is foreground; what stays in place for most of it (a person standing still, a parked ball) is
// background, and shadows are background. The hull, the masked metrics and the stability figure
// read these masks as they read a capture's own.
#include <vector>

#include "retimegs/core/image.hpp"

namespace retimegs::prepare {

struct MaskOptions {
  // A pixel is background when its colour matches the Gaussians that together hold this share of
  // its frames. At one half, content that covers a pixel in fewer than half of the frames (people
  // walking through it) stays foreground; OpenCV's 0.9 makes everything seen in two frames out of
  // seventeen background, most of what moves on a capture's short clip.
  double background_ratio = 0.5;
  double var_threshold = 16;  // MOG2: squared Mahalanobis distance of a match (4 sigma)
  // Cleaning: specks smaller than this share of the image are dropped, and gaps narrower than
  // this share of the image's larger side are closed.
  double min_area = 5e-4;
  double close_size = 0.01;
};

// Masks ([H, W, 1], 0 or 1) of every frame of one camera's clip (RGB or grey, 8-bit values, all
// of the camera's size). The model is learnt from the frames listed in `learn` (the training
// frames: what a held-out frame looks like stays out of it), twice over, so that the first are
// judged by the same model as the last; then every frame is classified against it without
// learning. Throws Error for fewer than 2 frames to learn from, an index outside the clip, or
// frames of different sizes.
std::vector<Image> background_masks(const std::vector<Image>& frames,
                                    const std::vector<std::size_t>& learn,
                                    const MaskOptions& options);

}  // namespace retimegs::prepare
