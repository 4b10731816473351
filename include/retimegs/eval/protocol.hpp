#pragma once
// The held-out evaluation protocol (docs/method.md, evaluation): render every listed camera at
// every listed frame, compare with the ground truth — PSNR inside the mask, SSIM on the mask's
// bounding box, LPIPS-squeeze on both images with the background outside the mask set to black
// (whole images when the scene has no masks), and the same three on the whole image — and average
// over views. Optionally also the temporal stability of an 8x slow-motion render.
#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "retimegs/core/image.hpp"
#include "retimegs/cuda/device.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/playback/model_renderer.hpp"
#include "retimegs/playback/render_model.hpp"
#include "retimegs/render/options.hpp"

namespace retimegs::eval {

// Produces the image of scene camera `camera` at `time`, a position among that camera's own frames
// (its frame k at k; in-between positions are fractional). A model renders it at the scene time
// of that position on the camera's clock (io::frame_time), so a frame is scored at its own time;
// the baselines blend the camera's own frames there.
using FrameRenderer = std::function<Image(int camera, double time)>;

struct EvalOptions {
  std::vector<int> frames;                             // scene frames
  std::vector<int> cameras;                            // scene camera indices
  std::optional<std::filesystem::path> lpips_weights;  // none: lpips = null
  std::optional<std::filesystem::path> save_renders;   // DIR/<camera>/<frame:05d>.png
  bool replace_renders = false;  // --force: an existing save_renders folder is replaced
  // Non-empty: also measure temporal_stability() of `cameras` through these training frames.
  std::vector<int> stability_frames;
  // A merged model's seams (model::Model::seams) as times: stability reports them apart.
  std::vector<double> seams;
  bool progress = true;
};

struct Scores {
  double psnr = 0, ssim = 0;
  std::optional<double> lpips;
};

struct ViewScore {
  std::string camera;
  int frame = 0;
  // A test camera (split "test": never trained on, a novel view) rather than a training camera's
  // held-out frame.
  bool test_camera = false;
  double psnr = 0, ssim = 0;  // inside the mask when `masked`
  std::optional<double> lpips;
  bool masked = false;
  Scores whole;  // the whole image (the same as above when not masked)
};

// Temporal stability (docs/method.md, evaluation) of one camera: the largest mean absolute change
// between consecutive frames of the slow-motion render over its static pixels, in 8-bit levels.
struct CameraStability {
  std::string camera;
  std::optional<double> max_change;  // none when the camera has no static pixel
  // The consecutive times between which it changed the most (the first such pair).
  std::optional<std::pair<double, double>> max_between;
  // The largest change over the steps that begin or end at a seam, and at a training frame that is
  // no seam: where a merged model's windows hand over, against where one window's intervals meet.
  // None when there is no such frame (or no static pixel).
  std::optional<double> at_seams, at_training_frames;
  double static_fraction = 0;  // of the image's pixels
  bool masked = false;         // static pixels from masks (else from pixel values)
  bool swept = false;          // ... and the masks' paths along the scene's flows
};

struct Stability {
  int steps = 0;  // renders per training interval
  std::vector<CameraStability> per_camera;
  std::optional<double> max, mean;  // over the cameras that have static pixels
  std::vector<double> seams;
  std::optional<double> max_at_seams, max_at_training_frames;  // over the cameras
};

// The mean over a set of views.
struct Summary {
  std::size_t views = 0;
  double psnr = 0, ssim = 0;  // inside the masks where the views have them
  std::optional<double> lpips;
  bool masked = false;  // every view was scored inside a mask
  Scores whole;
};

struct EvalResult {
  // Over every view scored.
  double psnr = 0, ssim = 0;
  std::optional<double> lpips;
  bool masked = false;  // every view was scored inside a mask
  Scores whole;
  // The two questions a held-out score answers, apart: how well the model fills in time for the
  // cameras it trained on (their held-out frames), and how well it renders views no training
  // camera had (the test cameras). A sparse rig can do the first well and the second badly; one
  // mean over both hides which. None where no view of that kind was scored.
  std::optional<Summary> train_views, test_views;
  std::vector<int> frames;
  std::vector<ViewScore> per_view;
  std::optional<Stability> stability;
  // The near plane the model was rendered with (render::RenderOptions::near_plane); none for a
  // baseline. evaluate_views() leaves it to the caller, who built the renderer.
  std::optional<double> near;
  std::string note;  // e.g. why lpips is null
};

EvalResult evaluate_views(const io::Scene& scene, const FrameRenderer& render,
                          const EvalOptions& options);

// The JSON of docs/method.md, evaluation: {"psnr", "ssim", "lpips" (or null), "masked", "whole":
// {"psnr", "ssim", "lpips"}, "train_views" and "test_views" (each {"views", "psnr", "ssim",
// "lpips", "masked", "whole"}, or null), "near" (or null), "frames", "per_view" (each with its
// "split", "train" or "test", and its own "whole")},
// and "stability": {"steps", "max", "mean", "seams", "max_at_seams", "max_at_training_frames",
// "per_camera": [{"camera", "max_change", "max_between", "at_seams", "at_training_frames",
// "static_fraction", "masked", "swept"}]} when measured.
std::string to_json(const EvalResult& result);
// That JSON and a newline, written atomically to `path`.
void write_json(const EvalResult& result, const std::filesystem::path& path, bool replace);

// The pixels of `camera` that are static in the ground truth. With a mask at every frame: outside
// the union over all frames of the masks and of their paths between frames, dilated by
// stability_dilation_radius() (a mask's soft edge, motion blur and shadows stay out). The path
// from frame k to the next frame j that the scene has a flow to (k -> j or j -> k) is swept by
// carrying each foreground pixel along the flow: an object that moves more than its own size per
// frame crosses, between frames, pixels no frame's mask covers, and a slow-motion render that
// draws it there is right, not unstable. Without masks at every frame: pixels whose value in no
// channel varies by more than one 8-bit level over all frames.
struct StaticPixels {
  std::vector<unsigned char> is_static;  // [H, W] 1 = static
  bool from_masks = false;
  bool swept = false;  // some of the masks' paths came from flows
};
StaticPixels static_pixels(const io::Scene& scene, int camera);
// 2 % of the image's larger side, at least one pixel: 13 px at 640x360, 6 px at 256x192.
int stability_dilation_radius(int width, int height);

// For each camera: render times a + k (b - a) / steps, k = 0 .. steps - 1, for each consecutive
// pair (a, b) of `train_frames` (sorted), then the last training frame, and take the largest mean
// absolute change (over the static pixels and channels, x 255) between consecutive renders. The
// ground truth would score 0; a model whose static world pulses at the training frames does not.
// `seams` (times, each a training frame) are reported apart from the other training frames.
Stability temporal_stability(const io::Scene& scene, const FrameRenderer& render,
                             const std::vector<int>& cameras, std::vector<int> train_frames,
                             const std::vector<double>& seams = {}, int steps = 8,
                             bool progress = true);

// In-betweening baselines over the training frames `train_frames` (sorted), at any time between
// them, of training cameras only (check_baseline_cameras): a test camera's own frames are what
// the model is scored against without ever seeing them, so blending them is no baseline for it.
// crossfade blends the two neighbouring training frames by time, nearest copies the closer one (the
// earlier on a tie), flow interpolates them along the optical flow between them
// (flow_interpolate.hpp: the scene's flow files, or estimated). Times outside the training range
// copy the end frame; a training frame is returned as it is. The renderer keeps the last pair's
// images and flows, so it is not safe to call from several threads.
enum class Baseline { kCrossfade, kNearest, kFlow };
FrameRenderer baseline_renderer(const io::Scene& scene, std::vector<int> train_frames,
                                Baseline baseline);
// Throws Error naming `flag` and the first test camera among `cameras` (scene indices).
void check_baseline_cameras(const io::Scene& scene, const std::vector<int>& cameras,
                            const std::string& flag);

// "crossfade" | "nearest" | "flow"; throws Error naming `flag` and the value otherwise.
Baseline parse_baseline(const std::string& name, const std::string& flag);

// The held-out renderer of a model: camera `camera` of `scene` as the model saw it
// (playback::seen_camera: a training camera through its pose correction) at frame position `time`
// (at scene time io::frame_time of it) on black, with that camera's colours
// (playback::Colors::kCamera), every render with `options`, on `device`
// (playback::ModelRenderer; the GPU's arrays are reused, so calls must not overlap). `scene` must
// outlive the returned renderer; the model is owned by it.
FrameRenderer model_renderer(const io::Scene& scene, playback::LoadedModel model,
                             const render::RenderOptions& options = {},
                             cuda::Device device = cuda::Device::kCpu);

// "odd", "all", or a comma-separated list; throws Error naming `flag` on bad input.
std::vector<int> parse_frames(const std::string& text, int num_frames, const std::string& flag);

}  // namespace retimegs::eval
