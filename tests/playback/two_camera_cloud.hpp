#pragma once
// A model of drifting primitives seen by two scene cameras, cam00 with a stored colour correction:
// which colours a render shows, in playback's tests and eval's.
#include <algorithm>
#include <cmath>
#include <string>

#include "retimegs/core/camera.hpp"
#include "retimegs/core/image.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/model/model_file.hpp"
#include "soft_cloud.hpp"

namespace retimegs::test {

struct TwoCameraCloud {
  io::Scene scene;
  model::Model model;
  TwoCameraCloud() {
    for (int c = 0; c < 2; ++c) {
      Camera cam;
      cam.name = "cam0" + std::to_string(c);
      cam.width = 40, cam.height = 30;
      cam.fx = cam.fy = 40, cam.cx = 20, cam.cy = 15;
      cam.world_to_camera = look_at({1.0 * c - 0.5, 0, -4.0}, {0, 0, 0}, {0, -1, 0});
      scene.cameras.push_back(cam);
    }
    scene.num_frames = 3;
    scene.fps = 24;
    model = soft_cloud({.count = 60, .seed = 3, .drift = 0.3f, .opacity_logit = 1.0f});
    model.camera_colors["cam00"] = {{0.3f, -0.2f, 0.1f}, {0.05f, -0.02f, 0.0f}};
  }
};

inline double max_abs_diff(const Image& a, const Image& b) {
  double d = 0;
  for (std::size_t i = 0; i < a.data.size(); ++i)
    d = std::max(d, double(std::abs(a.data[i] - b.data[i])));
  return d;
}

}  // namespace retimegs::test
