#include "retimegs/eval/protocol.hpp"

#include <algorithm>
#include <cmath>
#include <memory>

#include <nlohmann/json.hpp>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/core/progress.hpp"
#include "retimegs/core/psnr.hpp"
#include "retimegs/eval/flow_interpolate.hpp"
#include "retimegs/eval/lpips.hpp"
#include "retimegs/eval/metrics.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"

namespace retimegs::eval {
namespace fs = std::filesystem;

EvalResult evaluate_views(const io::Scene& scene, const FrameRenderer& render,
                          const EvalOptions& options) {
  EvalResult result;
  result.frames = options.frames;
  if (options.frames.empty()) fail("eval: no frames to evaluate");
  if (options.cameras.empty()) fail("eval: no cameras to evaluate");
  std::optional<Lpips> lpips;
  if (options.lpips_weights)
    lpips = Lpips::load(*options.lpips_weights);
  else
    result.note = "lpips: no weights given (--lpips-weights DIR), reported as null";

  std::optional<AtomicDirectory> renders;
  if (options.save_renders) renders.emplace(*options.save_renders, options.replace_renders);
  struct Job {
    int camera, frame;
  };
  std::vector<Job> jobs;
  for (int c : options.cameras)
    for (int k : options.frames) jobs.push_back({c, k});
  result.per_view.resize(jobs.size());
  Progress progress("eval", jobs.size(), options.progress);
  // The views are rendered one after another (the renderer uses every core, or the GPU), then
  // scored a batch at a time, one view per thread: a view's metrics (LPIPS's convolutions above
  // all) are too small to keep many cores busy. A batch holds its views' working memory at once,
  // about 48 floats a pixel (the render, the truth, the mask, their masked copies, and LPIPS's
  // widest layer: conv1's 64 maps at half resolution with their inputs); it stays within 4 GB.
  constexpr std::size_t kBatchBytes = std::size_t(4) << 30, kBytesPerPixel = 48 * sizeof(float);
  std::size_t pixels = 1;
  for (int c : options.cameras)
    pixels = std::max(pixels, std::size_t(scene.cameras[c].width) * scene.cameras[c].height);
  const std::size_t batch =
      std::clamp<std::size_t>(kBatchBytes / (kBytesPerPixel * pixels), 1, max_threads());
  std::vector<Image> images;
  for (std::size_t first = 0; first < jobs.size(); first += batch) {
    const std::size_t count = std::min(batch, jobs.size() - first);
    images.clear();
    for (std::size_t j = first; j < first + count; ++j)
      images.push_back(render(jobs[j].camera, jobs[j].frame));
    parallel_for(count, [&](std::size_t b) {
      const auto [c, k] = jobs[first + b];
      const Image& image = images[b];
      const Image truth = media::load_image(scene, c, k);
      std::optional<Image> mask = media::load_mask(scene, c, k);
      // A mask without foreground (nothing of interest in view) scores the whole image.
      if (mask &&
          std::none_of(mask->data.begin(), mask->data.end(), [](float m) { return m > 0.5f; }))
        mask.reset();
      ViewScore& v = result.per_view[first + b];
      v.camera = scene.cameras[c].name;
      v.frame = k;
      v.test_camera = scene.cameras[c].split == Split::kTest;
      v.masked = mask.has_value();
      v.whole.psnr = psnr(image, truth);
      v.whole.ssim = ssim_in_box(image, truth);
      if (lpips) v.whole.lpips = lpips->distance(image, truth);
      if (mask) {
        v.psnr = psnr(image, truth, &*mask);
        v.ssim = ssim_in_box(image, truth, &*mask);
        if (lpips) v.lpips = lpips->distance(apply_mask(image, *mask), apply_mask(truth, *mask));
      } else {
        v.psnr = v.whole.psnr, v.ssim = v.whole.ssim, v.lpips = v.whole.lpips;
      }
    });
    for (std::size_t b = 0; b < count; ++b) {
      const ViewScore& v = result.per_view[first + b];
      if (renders)
        media::write_png(renders->temp_path() / v.camera / fmt::format("{:05d}.png", v.frame),
                         images[b]);
      progress.tick();
    }
  }
  progress.finish();
  if (renders) renders->commit();
  const auto summary = [&](auto&& keep) -> std::optional<Summary> {
    Summary s;
    s.masked = true;
    for (const ViewScore& v : result.per_view) {
      if (!keep(v)) continue;
      ++s.views;
      s.masked = s.masked && v.masked;
      s.psnr += v.psnr, s.ssim += v.ssim;
      s.whole.psnr += v.whole.psnr, s.whole.ssim += v.whole.ssim;
      if (lpips) {
        s.lpips = s.lpips.value_or(0) + *v.lpips;
        s.whole.lpips = s.whole.lpips.value_or(0) + *v.whole.lpips;
      }
    }
    if (s.views == 0) return std::nullopt;
    const double n = double(s.views);
    s.psnr /= n, s.ssim /= n, s.whole.psnr /= n, s.whole.ssim /= n;
    if (s.lpips) *s.lpips /= n, *s.whole.lpips /= n;
    return s;
  };
  const Summary all = *summary([](const ViewScore&) { return true; });
  result.psnr = all.psnr, result.ssim = all.ssim, result.lpips = all.lpips;
  result.masked = all.masked, result.whole = all.whole;
  result.train_views = summary([](const ViewScore& v) { return !v.test_camera; });
  result.test_views = summary([](const ViewScore& v) { return v.test_camera; });
  if (!options.stability_frames.empty())
    result.stability = temporal_stability(scene, render, options.cameras, options.stability_frames,
                                          options.seams, /*steps=*/8, options.progress);
  return result;
}

namespace {

using json = nlohmann::json;

json optional_json(const std::optional<double>& value) {
  return value ? json(*value) : json(nullptr);
}

json scores_json(const Scores& s) {
  return {{"psnr", s.psnr}, {"ssim", s.ssim}, {"lpips", optional_json(s.lpips)}};
}

json summary_json(const std::optional<Summary>& s) {
  if (!s) return nullptr;
  return {{"views", s->views},   {"psnr", s->psnr},
          {"ssim", s->ssim},     {"lpips", optional_json(s->lpips)},
          {"masked", s->masked}, {"whole", scores_json(s->whole)}};
}

json stability_json(const Stability& s) {
  json cameras = json::array();
  for (const CameraStability& c : s.per_camera)
    cameras.push_back(
        {{"camera", c.camera},
         {"max_change", optional_json(c.max_change)},
         {"max_between", c.max_between ? json::array({c.max_between->first, c.max_between->second})
                                       : json(nullptr)},
         {"at_seams", optional_json(c.at_seams)},
         {"at_training_frames", optional_json(c.at_training_frames)},
         {"static_fraction", c.static_fraction},
         {"masked", c.masked},
         {"swept", c.swept}});
  return {{"steps", s.steps},
          {"max", optional_json(s.max)},
          {"mean", optional_json(s.mean)},
          {"seams", s.seams},
          {"max_at_seams", optional_json(s.max_at_seams)},
          {"max_at_training_frames", optional_json(s.max_at_training_frames)},
          {"per_camera", cameras}};
}

}  // namespace

std::string to_json(const EvalResult& r) {
  json views = json::array();
  for (const ViewScore& v : r.per_view)
    views.push_back({{"camera", v.camera},
                     {"frame", v.frame},
                     {"split", v.test_camera ? "test" : "train"},
                     {"psnr", v.psnr},
                     {"ssim", v.ssim},
                     {"lpips", optional_json(v.lpips)},
                     {"masked", v.masked},
                     {"whole", scores_json(v.whole)}});
  json j = {{"psnr", r.psnr},
            {"ssim", r.ssim},
            {"lpips", optional_json(r.lpips)},
            {"masked", r.masked},
            {"whole", scores_json(r.whole)},
            {"train_views", summary_json(r.train_views)},
            {"test_views", summary_json(r.test_views)},
            {"near", optional_json(r.near)},
            {"frames", r.frames},
            {"per_view", views}};
  if (r.stability) j["stability"] = stability_json(*r.stability);
  if (!r.note.empty()) j["note"] = r.note;
  return j.dump(2);
}

void write_json(const EvalResult& result, const fs::path& path, bool replace) {
  write_text_file(path, to_json(result) + "\n", replace);
}

namespace {

// The training pair a renderer last blended: consecutive times of a slow-motion render and the
// views of one camera share it.
struct PairCache {
  int camera = -1, a = -1, b = -1;
  Image image_a, image_b;
  std::optional<prepare::FlowPair> flows;
};

}  // namespace

FrameRenderer baseline_renderer(const io::Scene& scene, std::vector<int> train_frames,
                                Baseline baseline) {
  std::sort(train_frames.begin(), train_frames.end());
  if (train_frames.empty()) fail("baseline: no training frames");
  auto cache = std::make_shared<PairCache>();
  return [&scene, train_frames, baseline, cache](int camera, double time) {
    const auto hi = std::lower_bound(train_frames.begin(), train_frames.end(), time);
    if (hi == train_frames.end()) return media::load_image(scene, camera, train_frames.back());
    if (*hi == time || hi == train_frames.begin()) return media::load_image(scene, camera, *hi);
    const int a = *(hi - 1), b = *hi;
    const double s = (time - a) / double(b - a);
    if (baseline == Baseline::kNearest) return media::load_image(scene, camera, s <= 0.5 ? a : b);
    PairCache& c = *cache;
    if (c.camera != camera || c.a != a || c.b != b) {
      c.image_a = media::load_image(scene, camera, a);
      c.image_b = media::load_image(scene, camera, b);
      c.flows.reset();
      c.camera = camera, c.a = a, c.b = b;
    }
    if (baseline == Baseline::kFlow) {
      if (!c.flows) c.flows = flow_pair(scene, camera, a, b, c.image_a, c.image_b);
      return interpolate_flow(c.image_a, c.image_b, *c.flows, s);
    }
    Image out(c.image_a.width, c.image_a.height, c.image_a.channels);
    for (std::size_t i = 0; i < out.data.size(); ++i)
      out.data[i] = float((1 - s) * c.image_a.data[i] + s * c.image_b.data[i]);
    return out;
  };
}

FrameRenderer model_renderer(const io::Scene& scene, playback::LoadedModel model,
                             const render::RenderOptions& options, cuda::Device device) {
  // The scene's cameras as the model saw them in training (playback::seen_camera): a training
  // camera's held-out frames through its pose correction, test cameras as they are.
  std::vector<Camera> seen;
  for (const Camera& c : scene.cameras) seen.push_back(playback::seen_camera(model, c));
  // The camera's own clock, as the model learned it: its frame position p shows the scene at
  // playback::seen_time.
  auto renderer = std::make_shared<const playback::ModelRenderer>(std::move(model), device);
  return [&scene, seen = std::move(seen), renderer, options](int camera, double time) {
    const float black[3] = {0, 0, 0};
    return renderer->render(seen[camera],
                            playback::seen_time(renderer->model(), scene, camera, time), black,
                            options, playback::Colors::kCamera);
  };
}

void check_baseline_cameras(const io::Scene& scene, const std::vector<int>& cameras,
                            const std::string& flag) {
  for (int c : cameras)
    if (scene.cameras[c].split == Split::kTest)
      fail(
          "{}: camera {} is a test camera: a baseline blends a camera's own training frames, which "
          "a test camera has none of (score test cameras with --model)",
          flag, scene.cameras[c].name);
}

Baseline parse_baseline(const std::string& name, const std::string& flag) {
  if (name == "crossfade") return Baseline::kCrossfade;
  if (name == "nearest") return Baseline::kNearest;
  if (name == "flow") return Baseline::kFlow;
  fail("{}: '{}' is not crossfade, nearest or flow", flag, name);
}

std::vector<int> parse_frames(const std::string& text, int num_frames, const std::string& flag) {
  if (text == "odd") return io::held_out_frames(num_frames, io::FrameSelection::kEven);
  if (text == "all") return io::training_frames(num_frames, io::FrameSelection::kAll);
  std::vector<int> frames;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, comma - start);
    std::size_t used = 0;
    int k = -1;
    try {
      k = std::stoi(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != item.size() || item.empty() || k < 0 || k >= num_frames)
      fail("{}: '{}' is not odd, all, or a list of frames in 0..{}", flag, text, num_frames - 1);
    frames.push_back(k);
    start = comma + 1;
  }
  return frames;
}

}  // namespace retimegs::eval
