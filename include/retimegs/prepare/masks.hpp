#pragma once
// Approximate foreground masks for captures that have none (`retimegs prepare --masks`), from a
// background model of each static camera's own clip (OpenCV's MOG2 or KNN background
// subtractors), cleaned morphologically. What moves during the clip is foreground; what stays in
// place for most of it (a person standing still, a parked ball) is background, and shadows are
// background. The hull, the masked metrics and the stability figure read these masks as they read
// a capture's own.
#include <string>
#include <vector>

#include "retimegs/core/image.hpp"

namespace retimegs::prepare {

enum class MaskMethod { kMog2, kKnn };

// "mog2" or "knn"; throws Error naming --masks otherwise.
MaskMethod parse_mask_method(const std::string& name);
const char* mask_method_name(MaskMethod method);

struct MaskOptions {
  MaskMethod method = MaskMethod::kMog2;
  // MOG2: a pixel is background when its colour matches the Gaussians that together hold this
  // share of its clip. Below one half, content that covers a pixel for less than half of the
  // clip (people walking through it) stays foreground on the short clips of a capture, where
  // OpenCV's 0.9 makes everything seen in two frames out of seventeen background.
  double background_ratio = 0.5;
  double var_threshold = 16;   // MOG2: squared Mahalanobis distance of a match (4 sigma)
  double knn_threshold = 400;  // KNN: squared distance (8-bit RGB) of a match
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
