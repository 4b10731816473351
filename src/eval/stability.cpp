// Temporal stability of a slow-motion render over the pixels static in the ground truth
// (protocol.hpp, docs/method.md, evaluation).
#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/core/progress.hpp"
#include "retimegs/eval/protocol.hpp"
#include "retimegs/media/scene_images.hpp"

namespace retimegs::eval {
namespace {

// One 8-bit level; the tolerance absorbs float rounding of k / 255.
constexpr float kOneLevel = 1.0f / 255.0f + 1e-6f;

// Marks in `moving` the pixels that the foreground of `mask` crosses on its way along `flow` (to
// the frame the flow leads to): each known foreground pixel p sweeps p + s F(p), 0 < s < 1, in
// steps of at most a pixel.
void sweep_along_flow(const Image& mask, const Flow& flow, cv::Mat& moving) {
  const int w = flow.width, h = flow.height;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::size_t i = std::size_t(y) * w + x;
      if (!flow.valid[i] || !is_foreground(mask, i)) continue;
      const double u = flow.uv[2 * i], v = flow.uv[2 * i + 1];
      const int steps = int(std::ceil(std::hypot(u, v)));
      for (int k = 1; k < steps; ++k) {
        const int sx = int(std::lround(x + u * k / steps)),
                  sy = int(std::lround(y + v * k / steps));
        if (sx >= 0 && sy >= 0 && sx < w && sy < h) moving.at<unsigned char>(sy, sx) = 1;
      }
    }
}

}  // namespace

int stability_dilation_radius(int width, int height) {
  return std::max(1, int(std::lround(0.02 * std::max(width, height))));
}

StaticPixels static_pixels(const io::Scene& scene, int camera) {
  const Camera& cam = scene.cameras[camera];
  const std::size_t n = std::size_t(cam.width) * cam.height;
  StaticPixels result;
  cv::Mat moving(cam.height, cam.width, CV_8U, cv::Scalar(0));
  std::vector<Image> masks;
  for (int k = 0; k < scene.num_frames; ++k) {
    std::optional<Image> mask = media::load_mask(scene, camera, k);
    if (!mask) break;
    for (std::size_t i = 0; i < n; ++i)
      if (is_foreground(*mask, i)) moving.data[i] = 1;
    masks.push_back(std::move(*mask));
  }
  if (int(masks.size()) == scene.num_frames) {
    // Between frame k and the next frame j the scene has a flow to, the foreground's path.
    for (int k = 0; k < scene.num_frames; ++k)
      for (int j = k + 1; j < scene.num_frames; ++j) {
        const std::optional<Flow> forward = io::load_flow(scene, camera, k, j);
        const std::optional<Flow> backward = io::load_flow(scene, camera, j, k);
        if (forward) sweep_along_flow(masks[k], *forward, moving);
        if (backward) sweep_along_flow(masks[j], *backward, moving);
        if (forward || backward) {
          result.swept = true;
          break;
        }
      }
    const int r = stability_dilation_radius(cam.width, cam.height);
    cv::dilate(moving, moving,
               cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1)));
    result.from_masks = true;
    result.is_static.resize(n);
    for (std::size_t i = 0; i < n; ++i) result.is_static[i] = moving.data[i] ? 0 : 1;
    return result;
  }
  Image lo = media::load_image(scene, camera, 0), hi = lo;
  for (int k = 1; k < scene.num_frames; ++k) {
    const Image image = media::load_image(scene, camera, k);
    for (std::size_t i = 0; i < image.data.size(); ++i) {
      lo.data[i] = std::min(lo.data[i], image.data[i]);
      hi.data[i] = std::max(hi.data[i], image.data[i]);
    }
  }
  result.is_static.assign(n, 1);
  const int channels = lo.channels;
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < channels; ++c)
      if (hi.data[i * channels + c] - lo.data[i * channels + c] > kOneLevel)
        result.is_static[i] = 0;
  return result;
}

Stability temporal_stability(const io::Scene& scene, const FrameRenderer& render,
                             const std::vector<int>& cameras, std::vector<int> train_frames,
                             const std::vector<double>& seams, int steps, bool progress) {
  std::sort(train_frames.begin(), train_frames.end());
  if (train_frames.size() < 2) fail("stability: needs at least two training frames");
  if (steps < 1) fail("stability: steps must be positive, got {}", steps);
  // Where each render lies: at a seam, at another training frame, or between training frames.
  enum class At { kBetween, kTrainingFrame, kSeam };
  const auto is_seam = [&](double t) {
    return std::any_of(seams.begin(), seams.end(),
                       [t](double s) { return std::abs(s - t) < 1e-9; });
  };
  for (const double s : seams)
    if (!std::binary_search(train_frames.begin(), train_frames.end(), int(std::lround(s))) ||
        std::abs(s - std::lround(s)) > 1e-9)
      fail("stability: seam {} is not one of the training frames {}..{}", s, train_frames.front(),
           train_frames.back());
  std::vector<double> times;
  std::vector<At> at;
  const auto add_frame = [&](int frame) {
    times.push_back(frame);
    at.push_back(is_seam(frame) ? At::kSeam : At::kTrainingFrame);
  };
  for (std::size_t i = 0; i + 1 < train_frames.size(); ++i) {
    add_frame(train_frames[i]);
    for (int k = 1; k < steps; ++k) {
      times.push_back(train_frames[i] +
                      double(k) * (train_frames[i + 1] - train_frames[i]) / steps);
      at.push_back(At::kBetween);
    }
  }
  add_frame(train_frames.back());
  const auto touches = [&](std::size_t j, At where) {
    return at[j - 1] == where || at[j] == where;
  };
  const auto raise = [](std::optional<double>& largest, double value) {
    largest = std::max(largest.value_or(value), value);
  };

  Stability result;
  result.steps = steps;
  result.seams = seams;
  Progress bar("stability", cameras.size() * (times.size() - 1), progress);
  double sum = 0;
  int counted = 0;
  for (int c : cameras) {
    const StaticPixels still = static_pixels(scene, c);
    CameraStability s;
    s.camera = scene.cameras[c].name;
    s.masked = still.from_masks, s.swept = still.swept;
    const std::size_t n = still.is_static.size();
    const std::size_t count = std::count(still.is_static.begin(), still.is_static.end(), 1);
    s.static_fraction = double(count) / double(n);
    if (count > 0) {
      Image previous = render(c, times[0]);
      double largest = -1;
      for (std::size_t j = 1; j < times.size(); ++j) {
        Image current = render(c, times[j]);
        const int channels = current.channels;
        double change = 0;
        for (std::size_t i = 0; i < n; ++i) {
          if (!still.is_static[i]) continue;
          for (int ch = 0; ch < channels; ++ch)
            change += std::abs(double(current.data[i * channels + ch]) -
                               double(previous.data[i * channels + ch]));
        }
        change *= 255.0 / (double(count) * channels);
        if (change > largest) largest = change, s.max_between = {times[j - 1], times[j]};
        if (touches(j, At::kSeam)) raise(s.at_seams, change);
        if (touches(j, At::kTrainingFrame)) raise(s.at_training_frames, change);
        previous = std::move(current);
        bar.tick();
      }
      s.max_change = largest;
      result.max = std::max(result.max.value_or(0), largest);
      if (s.at_seams) raise(result.max_at_seams, *s.at_seams);
      if (s.at_training_frames) raise(result.max_at_training_frames, *s.at_training_frames);
      sum += largest, ++counted;
    }
    result.per_camera.push_back(s);
  }
  bar.finish();
  if (counted > 0) result.mean = sum / counted;
  return result;
}

}  // namespace retimegs::eval
