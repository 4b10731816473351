#pragma once
// Settings shared by every stage of the rasteriser (README.md, Architecture). Defaults are gsplat
// v1 / 3DGS; the gsplat v0.1.13 reference renders in data/gsplat-reference use `gsplat_v0_1_13()`.
#include "retimegs/core/hd.hpp"

namespace retimegs::render {

constexpr int kTileSize = 16;  // pixels per tile side (gsplat BLOCK_X = BLOCK_Y = 16)
// Tiles along an image side of `pixels` (the last one may be partly outside).
RETIMEGS_HD constexpr int tile_count(int pixels) {
  return (pixels + kTileSize - 1) / kTileSize;
}

// When compositing stops: the Gaussian that would bring the transmittance under the threshold is
// not added, and the pixel is done. 3DGS and gsplat v1 test `T' < t`, gsplat v0.1.13 `T' <= t`.
enum class StopRule { kBelow, kAtOrBelow };

struct RenderOptions {
  float alpha_clamp = 0.99f;        // alpha = min(alpha_clamp, opacity * G)
  float min_alpha = 1.0f / 255.0f;  // contributions below one 8-bit step are skipped
  float min_transmittance = 1e-4f;  // early termination threshold (see StopRule)
  StopRule stop_rule = StopRule::kBelow;
  float low_pass = 0.3f;     // EWA low-pass added to the 2-D covariance diagonal, px^2
  float near_plane = 0.01f;  // camera z below which a Gaussian is culled
  // The centre is projected as f * x / (z + centre_depth_offset) + c. gsplat v0.1.13 adds 1e-6
  // (up to ~3e-4 px on its test cases, enough to flip alpha >= 1/255 decisions); gsplat v1 none.
  float centre_depth_offset = 0.0f;
  // Bin a Gaussian only into the tiles that its alpha >= min_alpha ellipse reaches (as well as
  // its 3-sigma radius square). Exact: a skipped tile could only have received alpha < min_alpha.
  bool tight_tile_bounds = true;
  bool render_depth = false;  // also composite camera z (accumulated, not normalised)
};

// The settings of the gsplat v0.1.13 pure-torch reference (its README, "Exact conventions").
inline RenderOptions gsplat_v0_1_13() {
  RenderOptions o;
  o.alpha_clamp = 0.999f;
  o.stop_rule = StopRule::kAtOrBelow;
  o.centre_depth_offset = 1e-6f;
  return o;
}

}  // namespace retimegs::render
