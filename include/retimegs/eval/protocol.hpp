#pragma once
// The held-out evaluation protocol (DESIGN.md §5): render every listed camera at every listed
// frame, compare with the ground truth — PSNR inside the mask, SSIM on the mask's bounding box,
// LPIPS-squeeze on both images with the background outside the mask set to black (whole images
// when the scene has no masks) — and average over views.
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "retimegs/core/image.hpp"
#include "retimegs/io/scene.hpp"

namespace retimegs::eval {

// Produces the image of scene camera `camera` at scene frame `frame`.
using FrameRenderer = std::function<Image(int camera, int frame)>;

struct EvalOptions {
  std::vector<int> frames;                             // scene frames
  std::vector<int> cameras;                            // scene camera indices
  std::optional<std::filesystem::path> lpips_weights;  // none: lpips = null
  std::optional<std::filesystem::path> save_renders;   // DIR/<camera>/<frame:05d>.png
  bool progress = true;
};

struct ViewScore {
  std::string camera;
  int frame = 0;
  double psnr = 0, ssim = 0;
  std::optional<double> lpips;
  bool masked = false;
};

struct EvalResult {
  double psnr = 0, ssim = 0;
  std::optional<double> lpips;
  bool masked = false;  // every view was scored inside a mask
  std::vector<int> frames;
  std::vector<ViewScore> per_view;
  std::string note;  // e.g. why lpips is null
};

EvalResult evaluate_views(const io::Scene& scene, const FrameRenderer& render,
                          const EvalOptions& options);

// The JSON of DESIGN.md §5: {"psnr", "ssim", "lpips" (or null), "masked", "frames", "per_view"}.
std::string to_json(const EvalResult& result);
// That JSON and a newline, written atomically to `path`.
void write_json(const EvalResult& result, const std::filesystem::path& path);

// Trivial in-betweening baselines over the training frames `train_frames` (sorted): crossfade
// blends the two neighbouring training frames by time, nearest copies the closer one (the earlier
// on a tie). Frames outside the training range copy the end frame.
enum class Baseline { kCrossfade, kNearest };
FrameRenderer baseline_renderer(const io::Scene& scene, std::vector<int> train_frames,
                                Baseline baseline);

// "odd", "all", or a comma-separated list; throws Error naming `flag` on bad input.
std::vector<int> parse_frames(const std::string& text, int num_frames, const std::string& flag);

}  // namespace retimegs::eval
