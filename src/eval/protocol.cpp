#include "retimegs/eval/protocol.hpp"

#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/progress.hpp"
#include "retimegs/core/psnr.hpp"
#include "retimegs/eval/lpips.hpp"
#include "retimegs/eval/metrics.hpp"
#include "retimegs/io/image_io.hpp"
#include "retimegs/io/training_views.hpp"

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
  if (options.save_renders) renders.emplace(*options.save_renders, /*replace=*/true);
  struct Job {
    int camera, frame;
  };
  std::vector<Job> jobs;
  for (int c : options.cameras)
    for (int k : options.frames) jobs.push_back({c, k});
  result.per_view.resize(jobs.size());
  Progress progress("eval", jobs.size(), options.progress);
  result.masked = true;
  for (std::size_t j = 0; j < jobs.size(); ++j) {
    const auto [c, k] = jobs[j];
    const Image image = render(c, k);
    const Image truth = io::load_image(scene, c, k);
    std::optional<Image> mask = io::load_mask(scene, c, k);
    // A mask without foreground (nothing of interest in view) scores the whole image.
    if (mask &&
        std::none_of(mask->data.begin(), mask->data.end(), [](float m) { return m > 0.5f; }))
      mask.reset();
    ViewScore& v = result.per_view[j];
    v.camera = scene.cameras[c].name;
    v.frame = k;
    v.masked = mask.has_value();
    result.masked &= v.masked;
    const Image* m = mask ? &*mask : nullptr;
    v.psnr = psnr(image, truth, m);
    v.ssim = ssim_in_box(image, truth, m);
    if (lpips)
      v.lpips = mask ? lpips->distance(apply_mask(image, *mask), apply_mask(truth, *mask))
                     : lpips->distance(image, truth);
    if (renders)
      io::write_png(renders->temp_path() / v.camera / fmt::format("{:05d}.png", k), image);
    progress.tick();
  }
  progress.finish();
  if (renders) renders->commit();
  double psnr_sum = 0, ssim_sum = 0, lpips_sum = 0;
  for (const ViewScore& v : result.per_view) {
    psnr_sum += v.psnr, ssim_sum += v.ssim;
    if (v.lpips) lpips_sum += *v.lpips;
  }
  const double n = double(result.per_view.size());
  result.psnr = psnr_sum / n, result.ssim = ssim_sum / n;
  if (lpips) result.lpips = lpips_sum / n;
  return result;
}

std::string to_json(const EvalResult& r) {
  using json = nlohmann::json;
  json views = json::array();
  for (const ViewScore& v : r.per_view)
    views.push_back({{"camera", v.camera},
                     {"frame", v.frame},
                     {"psnr", v.psnr},
                     {"ssim", v.ssim},
                     {"lpips", v.lpips ? json(*v.lpips) : json(nullptr)},
                     {"masked", v.masked}});
  json j = {{"psnr", r.psnr},
            {"ssim", r.ssim},
            {"lpips", r.lpips ? json(*r.lpips) : json(nullptr)},
            {"masked", r.masked},
            {"frames", r.frames},
            {"per_view", views}};
  if (!r.note.empty()) j["note"] = r.note;
  return j.dump(2);
}

void write_json(const EvalResult& result, const fs::path& path) {
  write_text_file(path, to_json(result) + "\n");
}

FrameRenderer baseline_renderer(const io::Scene& scene, std::vector<int> train_frames,
                                Baseline baseline) {
  std::sort(train_frames.begin(), train_frames.end());
  if (train_frames.empty()) fail("baseline: no training frames");
  return [&scene, train_frames, baseline](int camera, int frame) {
    const auto hi = std::lower_bound(train_frames.begin(), train_frames.end(), frame);
    if (hi == train_frames.end()) return io::load_image(scene, camera, train_frames.back());
    if (*hi == frame || hi == train_frames.begin()) return io::load_image(scene, camera, *hi);
    const int a = *(hi - 1), b = *hi;
    const double s = double(frame - a) / double(b - a);
    if (baseline == Baseline::kNearest) return io::load_image(scene, camera, s <= 0.5 ? a : b);
    Image ia = io::load_image(scene, camera, a);
    const Image ib = io::load_image(scene, camera, b);
    for (std::size_t i = 0; i < ia.data.size(); ++i)
      ia.data[i] = float((1 - s) * ia.data[i] + s * ib.data[i]);
    return ia;
  };
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
