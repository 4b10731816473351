#pragma once
// A small 4D model and a two-camera scene built directly (no training), holding every case the
// viewer's time model must reproduce: primitives stretched over the whole clip (open windows at
// both clip ends, positions on the Catmull-Rom curve's linear continuation), per-interval
// primitives whose windows open at the first and last training time, windows with a soft edge in
// the middle of an interval, rotating primitives, degree-3 SH, and a colour map on one camera.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>

#include "retimegs/io/scene.hpp"
#include "retimegs/model/model_file.hpp"

namespace retimegs::test {

// Training frames 0, 2, ..., 8 (scene frames 0..8); `count` primitives, deterministic per seed.
inline model::Model view_fixture_model(std::size_t count, unsigned seed) {
  model::Model m;
  m.grid = {0.0, 2.0, 5};
  m.config.sh_degree = 3;
  m.config.gamma = 0.02;  // 0.16 frames: soft edges wide enough to see at an in-between time
  model::Primitives& p = m.primitives;
  p.resize(count);
  std::mt19937 rng(seed);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
  for (std::size_t i = 0; i < count; ++i) {
    const int kind = int(i % 4);
    // 0: stretched over the clip (μ_τ = 3, window [0, 8]): outside [2, 4] the position follows
    //    the linear continuation; 1: per interval [2k, 2k + 2]; 2: a soft edge at t = 3.5 or
    //    5.5; 3: static background, stretched and still.
    const bool background = kind == 3;
    const float spread = background ? 2.5f : 1.0f;
    for (int a = 0; a < 3; ++a) p.mu[3 * i + a] = spread * uniform(rng);
    if (background) p.mu[3 * i + 2] = 2.0f + 0.5f * uniform(rng);  // behind the subject
    const float speed = background ? 0.0f : 0.08f;
    for (int k = 0; k < 9; ++k) p.velocity[9 * i + k] = speed * normal(rng);
    // Sizes shrink as the count grows (as in a trained model), keeping the overdraw per pixel
    // about that of 4000 primitives.
    const float size = -3.2f - std::log(float(count) / 4000.0f) / 3.0f;
    for (int a = 0; a < 3; ++a) p.log_scale[3 * i + a] = size + 0.5f * normal(rng);
    for (int a = 0; a < 4; ++a) p.q0[4 * i + a] = normal(rng);
    for (int a = 0; a < 4; ++a) p.q1[4 * i + a] = kind == 0 ? 0.1f * normal(rng) : 0.0f;
    for (int k = 0; k < model::Primitives::kShWidth; ++k)
      p.sh[model::Primitives::kShWidth * i + k] = (k < 3 ? 1.2f : 0.15f) * normal(rng);
    p.opacity_logit[i] = 1.0f + normal(rng);
    const int interval = int(i / 4) % 4;  // [2k, 2k + 2]
    switch (kind) {
      case 0:
      case 3:
        p.mu_tau[i] = 3.0f, p.tau_l[i] = 3.0f, p.tau_r[i] = 5.0f;
        break;
      case 1:
        p.mu_tau[i] = 2.0f * interval + 1.0f, p.tau_l[i] = 1.0f, p.tau_r[i] = 1.0f;
        break;
      default:
        p.mu_tau[i] = (i / 4) % 2 ? 3.0f : 5.0f, p.tau_l[i] = 1.0f, p.tau_r[i] = 0.5f;
        break;
    }
  }
  m.camera_colors["cam0"] = {{0.15f, -0.1f, 0.05f}, {0.03f, 0.0f, -0.02f}};
  return m;
}

// A merged model on the fixture's scene: the fixture's primitives held still (no motion, no
// rotation over time), a seam at t = 4 (training frame 2) with a fade of 0.25 intervals (F = 0.5
// frames: each side's weight is within model::kHandoverTail of 1 beyond 3.12 frames of the seam).
// The background belongs to both windows ([0, 8]); of the other primitives, alternate groups of
// four to the window before the seam ([0, 4]) or after it ([4, 8]). Each side alone then draws
// the same image at every time: the one before at t = 0, the one after at t = 8, and the frame
// at t is their mix by the handover's weight (playback::ModelRenderer::draw). Colours lie in
// [0.1, 0.9] whatever the view (the SH beyond degree 0 are zero), so no image over black clamps:
// the mix of two 8-bit images is the 8-bit image of the mix.
inline model::Model view_fixture_merged_model(std::size_t count, unsigned seed) {
  model::Model m = view_fixture_model(count, seed);
  m.config.seams = {2};
  m.config.seam_fade = 0.25;
  model::Primitives& p = m.primitives;
  constexpr int kSh = model::Primitives::kShWidth;
  for (std::size_t i = 0; i < count; ++i) {
    std::fill_n(&p.velocity[9 * i], 9, 0.0f);
    std::fill_n(&p.q1[4 * i], 4, 0.0f);
    // colour = 0.2821 h0 + 0.5 (model/sh.cpp): |h0| <= 1.4 keeps it within [0.1, 0.9].
    for (int k = 0; k < 3; ++k) p.sh[kSh * i + k] = std::clamp(p.sh[kSh * i + k], -1.4f, 1.4f);
    std::fill(&p.sh[kSh * i + 3], &p.sh[kSh * (i + 1)], 0.0f);
    if (i % 4 == 3) continue;  // the background: [0, 8]
    p.mu_tau[i] = (i / 4) % 2 ? 2.0f : 6.0f, p.tau_l[i] = 2.0f, p.tau_r[i] = 2.0f;
  }
  return m;
}

// Two cameras 4 units from the origin looking at it, 160x120 (cam0 train, cam1 test).
inline io::Scene view_fixture_scene(const std::filesystem::path& root) {
  io::Scene s;
  s.root = root;
  s.num_frames = 9;
  s.fps = 10;
  const double angles[2] = {-0.35, 0.5};
  for (int c = 0; c < 2; ++c) {
    Camera cam;
    cam.name = "cam" + std::to_string(c);
    cam.width = 160, cam.height = 120;
    cam.fx = cam.fy = 150;
    cam.cx = 80, cam.cy = 60;
    const Eigen::Vector3d eye(4 * std::sin(angles[c]), -0.6 * c, -4 * std::cos(angles[c]));
    cam.world_to_camera = look_at(eye, Eigen::Vector3d::Zero(), s.up);
    cam.split = c == 0 ? Split::kTrain : Split::kTest;
    s.cameras.push_back(cam);
  }
  return s;
}

}  // namespace retimegs::test
