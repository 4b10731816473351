#pragma once
// The CLI tests' 4D fixture: a 9-frame, 2-camera scene (JSON only) at ROOT/scene and a model of 200
// moving, turning primitives over its even frames at ROOT/model.rgs.
#include <cmath>
#include <filesystem>
#include <random>
#include <string>

#include "retimegs/io/scene.hpp"
#include "retimegs/model/model_file.hpp"
#include "test_util.hpp"

namespace retimegs::test {

struct MovingModelScene {
  io::Scene scene;
  model::Model model;
  std::filesystem::path model_path;
  explicit MovingModelScene(const std::filesystem::path& root) : model_path(root / "model.rgs") {
    scene.root = root / "scene";
    scene.num_frames = 9;
    scene.fps = 24;
    for (int c = 0; c < 2; ++c)
      scene.cameras.push_back(
          small_camera("cam0" + std::to_string(c), {2.0 * c - 1.0, -0.5, -4.0}));
    io::write_scene_json(scene);
    model.grid = {0.0, 2.0, 5};
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> u(-1, 1);
    model::Primitives& p = model.primitives;
    const int n = 200;
    p.resize(n);
    for (int i = 0; i < n; ++i) {
      for (int a = 0; a < 3; ++a) p.mu[3 * i + a] = u(rng);
      for (int k = 0; k < 9; ++k) p.velocity[9 * i + k] = (k % 3 == 0 ? 0.3f : 0.05f * u(rng));
      for (int a = 0; a < 3; ++a) p.log_scale[3 * i + a] = std::log(0.08f + 0.04f * u(rng));
      p.q0[4 * i] = 1, p.q0[4 * i + 1] = 0.3f * u(rng);
      p.q1[4 * i + 2] = 0.1f * u(rng);
      for (int k = 0; k < 48; ++k) p.sh[48 * i + k] = (k < 3 ? 1.0f : 0.1f) * u(rng);
      p.opacity_logit[i] = 1.0f + u(rng);
      p.mu_tau[i] = 1.0f + 2.0f * (i % 4);
      p.tau_l[i] = p.tau_r[i] = 1.0f;
    }
    model::write_model(model_path, model);
  }
};

}  // namespace retimegs::test
