#include "retimegs/io/training_views.hpp"

#include <algorithm>
#include <charconv>
#include <string_view>

#include "retimegs/core/error.hpp"

namespace retimegs::io {

namespace {

double cameras_extent(const Scene& scene, const std::vector<int>& cameras) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int c : cameras) mean += scene.cameras[c].center();
  mean /= double(std::max<std::size_t>(cameras.size(), 1));
  double radius = 0;
  for (int c : cameras) radius = std::max(radius, (scene.cameras[c].center() - mean).norm());
  return radius > 0 ? 1.1 * radius : 1.0;
}

}  // namespace

FrameSelection parse_frame_selection(const std::string& text, const std::string& flag) {
  if (text == "even") return FrameSelection::kEven;
  if (text == "all") return FrameSelection::kAll;
  fail("{}: must be even or all, got '{}'", flag, text);
}

FrameWindow parse_frame_window(const std::string& text, const std::string& flag) {
  const auto colon = text.find(':');
  FrameWindow w{-1, -1};
  const auto parse = [&](std::string_view part, int& value) {
    const auto [end, ec] = std::from_chars(part.data(), part.data() + part.size(), value);
    return ec == std::errc() && end == part.data() + part.size();
  };
  if (colon == std::string::npos || !parse(std::string_view(text).substr(0, colon), w.first) ||
      !parse(std::string_view(text).substr(colon + 1), w.last) || w.first < 0 || w.last <= w.first)
    fail("{}: expected A:B, scene frames with 0 <= A < B, got '{}'", flag, text);
  return w;
}

std::vector<int> training_cameras(const Scene& scene) {
  std::vector<int> cameras;
  for (int c = 0; c < int(scene.cameras.size()); ++c)
    if (scene.cameras[c].split == Split::kTrain) cameras.push_back(c);
  return cameras;
}

int frame_step(FrameSelection which) {
  return which == FrameSelection::kEven ? 2 : 1;
}

std::vector<int> training_frames(int num_frames, FrameSelection which) {
  std::vector<int> frames;
  for (int k = 0; k < num_frames; k += frame_step(which)) frames.push_back(k);
  return frames;
}

std::vector<int> held_out_frames(int num_frames, FrameSelection which) {
  const std::vector<int> train = training_frames(num_frames, which);
  std::vector<int> frames;
  for (int k = 0; k < num_frames; ++k)
    if (!std::binary_search(train.begin(), train.end(), k)) frames.push_back(k);
  return frames;
}

TrainingViews training_views(const Scene& scene, FrameSelection which) {
  TrainingViews views;
  views.cameras = training_cameras(scene);
  views.step = frame_step(which);
  views.frames = training_frames(scene.num_frames, which);
  for (std::size_t i = 0; i + 1 < views.frames.size(); ++i)
    views.flow_pairs.emplace_back(views.frames[i], views.frames[i + 1]);
  views.clip_frames = views.frames;
  views.extent = cameras_extent(scene, views.cameras);
  return views;
}

TrainingViews training_views(const Scene& scene, FrameSelection which, const FrameWindow& window) {
  TrainingViews views = training_views(scene, which);
  const std::vector<int>& clip = views.clip_frames;
  for (const int end : {window.first, window.last})
    if (!std::binary_search(clip.begin(), clip.end(), end))
      fail(
          "{}: window {}:{}: frame {} is not a training frame of the clip (frames 0, {}, {}, ... "
          "below {}): windows start and end on training frames so that neighbours share one",
          scene.json_path().string(), window.first, window.last, end, views.step, 2 * views.step,
          scene.num_frames);
  views.frames.clear();
  views.flow_pairs.clear();
  for (const int k : clip)
    if (k >= window.first && k <= window.last) views.frames.push_back(k);
  for (std::size_t i = 0; i + 1 < clip.size(); ++i)
    if (clip[i + 1] >= window.first && clip[i] <= window.last)
      views.flow_pairs.emplace_back(clip[i], clip[i + 1]);
  return views;
}

double scene_extent(const Scene& scene) {
  return cameras_extent(scene, training_cameras(scene));
}

double scene_near_plane(const Scene& scene) {
  return kNearPlaneFraction * scene_extent(scene);
}

Box cameras_look_box(const Scene& scene, const std::vector<int>& cameras) {
  if (cameras.empty()) fail("{}: no cameras to bound the scene", scene.json_path().string());
  const double extent = cameras_extent(scene, cameras);
  Box box;
  for (int c : cameras) {
    const Camera& cam = scene.cameras[c];
    box.centre += cam.center() + cam.rotation().row(2).transpose() * extent;
  }
  box.centre /= double(cameras.size());
  box.half = 0.5 * extent;
  return box;
}

}  // namespace retimegs::io
