// The CUDA training step (train/cuda_step.hpp) against the CPU step on the tiny in-memory scene
// (tiny_scene.hpp, with flows added so that every part of the recipe runs): the first steps' losses
// and parameter updates, repeatability, training quality, the strategy's host reshaping and
// checkpoints that resume on either device.
//
// Tolerances. The two steps run the same formulas, but nvcc and g++ contract different products
// into fused multiply-adds, the device's exp/log round their last bit their own way, the GPU's
// SSIM runs in float (the CPU's in double) and its backward adds gradients in the order the
// atomics land. A first step from the same parameters therefore gives losses equal to ~1e-6
// relative; its Adam update is lr · sign(g) for every value whose gradient is well above rounding,
// so the updates agree in sign except where a gradient is within rounding of zero.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "cuda/require_gpu.hpp"
#include "cuda_train/tiny_scene.hpp"
#include "retimegs/core/psnr.hpp"
#include "retimegs/model/slice.hpp"
#include "retimegs/render/rasterize.hpp"
#include "retimegs/train/cpu_step.hpp"
#include "retimegs/train/step.hpp"
#include "test_util.hpp"

namespace retimegs::train {
namespace {
namespace fs = std::filesystem;

// The tiny scene over 5 frames (3 interior ones: triple rendering) with 3 cameras, and its flows:
// the ball's pixels move by its centre's displacement in the image, the background stays
// (flow 0); every pixel known.
TrainingSet flow_scene(std::vector<double> time_offsets = {}) {
  test::TinySceneOptions options;
  options.cameras = 3;
  options.frames = 5;
  options.time_offsets = std::move(time_offsets);
  TrainingSet set = test::tiny_training_set(options);
  const int nf = int(set.frames.size());
  for (std::size_t c = 0; c < set.cameras.size(); ++c) {
    const Camera& cam = set.scene.cameras[set.cameras[c]];
    const auto centre_px = [&](int frame) {
      return cam.project_cam(cam.world_to_cam(test::tiny_ball_centre(frame)));
    };
    for (int i = 0; i < nf; ++i) {
      const Eigen::Vector2d here = centre_px(set.frames[i]);
      const double radius = cam.fx * test::kTinyBallRadius /
                            cam.world_to_cam(test::tiny_ball_centre(set.frames[i])).z();
      const auto flow_to = [&](int j) {
        const Eigen::Vector2d d = centre_px(set.frames[j]) - here;
        Flow f(cam.width, cam.height);
        for (int y = 0; y < cam.height; ++y)
          for (int x = 0; x < cam.width; ++x) {
            const bool ball = (Eigen::Vector2d(x + 0.5, y + 0.5) - here).norm() < radius;
            const std::size_t p = std::size_t(y) * cam.width + x;
            f.uv[2 * p] = ball ? float(d.x()) : 0.0f;
            f.uv[2 * p + 1] = ball ? float(d.y()) : 0.0f;
            f.valid[p] = 1;
          }
        return f;
      };
      if (i + 1 < nf) set.forward[c][i] = flow_to(i + 1);
      if (i > 0) set.backward[c][i] = flow_to(i - 1);
    }
  }
  return set;
}

TrainConfig tiny_config(int iters) {
  TrainConfig config;
  config.iters = iters;
  config.cap = 3000;
  return config;
}

// The CUDA step and a CPU step from the same initial primitives.
struct Pair {
  std::unique_ptr<TrainingStep> gpu;
  CpuStep cpu;
  Pair(const TrainingSet& set, const TrainConfig& config) : cpu(set, config) {
    cpu.initialize();
    gpu = make_step(set, config, cuda::Device::kCuda);
    gpu->initialize(cpu.model().primitives);
  }
};

double relative(double a, double b) {
  return std::abs(a - b) / std::max({std::abs(a), std::abs(b), 1e-12});
}

TEST(CudaStep, FirstStepLossesMatchTheCpu) {
  RETIMEGS_REQUIRE_GPU();
  const TrainingSet set = flow_scene();
  // Views at an end frame (one render) and interior frames (three renders with flow), every camera.
  const int views[][2] = {{0, 0}, {1, 2}, {2, 4}, {0, 3}};
  for (const auto& [c, i] : views) {
    Pair pair(set, tiny_config(200));
    const StepStats g = pair.gpu->step_view(c, i), h = pair.cpu.step_view(c, i);
    SCOPED_TRACE("view camera " + std::to_string(c) + " frame " + std::to_string(i));
    EXPECT_EQ(g.renders, h.renders);
    EXPECT_EQ(g.active, h.active);
    EXPECT_EQ(g.primitives, h.primitives);
    EXPECT_GT(h.flow_loss, 0) << "the flow path runs";
    EXPECT_LT(relative(g.image_loss, h.image_loss), 1e-4) << g.image_loss << " vs " << h.image_loss;
    EXPECT_LT(relative(g.flow_loss, h.flow_loss), 1e-4) << g.flow_loss << " vs " << h.flow_loss;
    EXPECT_LT(relative(g.loss, h.loss), 1e-4) << g.loss << " vs " << h.loss;
    EXPECT_NEAR(g.psnr, h.psnr, 1e-3);
    EXPECT_EQ(g.lr_means, h.lr_means);
  }
}

// A camera on its own clock (camera 1 half a frame late): its views are off the grid, one render
// at the view's own time over the rows of the two grid slots around it, on both devices alike;
// the views of the other cameras keep their triple rendering.
TEST(CudaStep, ViewsOffTheGridMatchTheCpu) {
  RETIMEGS_REQUIRE_GPU();
  const TrainingSet set = flow_scene({0, 0.5, 0});
  const int views[][2] = {{1, 0}, {1, 2}, {1, 4}, {0, 2}};
  for (const auto& [c, i] : views) {
    Pair pair(set, tiny_config(200));
    const StepStats g = pair.gpu->step_view(c, i), h = pair.cpu.step_view(c, i);
    SCOPED_TRACE("view camera " + std::to_string(c) + " frame " + std::to_string(i));
    EXPECT_EQ(h.renders, set.on_grid(c, i) ? 3 : 1);
    EXPECT_EQ(g.renders, h.renders);
    EXPECT_EQ(g.active, h.active);
    EXPECT_LT(relative(g.image_loss, h.image_loss), 1e-4) << g.image_loss << " vs " << h.image_loss;
    EXPECT_LT(relative(g.loss, h.loss), 1e-4) << g.loss << " vs " << h.loss;
    EXPECT_NEAR(g.psnr, h.psnr, 1e-3);
  }
}

// Camera refinement from the first step: both devices take the same gradient of each camera's
// correction (the device's sums of the render's Gaussians against the CPU's) and step it alike.
TEST(CudaStep, CameraRefinementMatchesTheCpu) {
  RETIMEGS_REQUIRE_GPU();
  const TrainingSet set = flow_scene();
  TrainConfig config = tiny_config(200);
  config.refine_cameras = true;
  config.camera_refine_start = 0;
  Pair pair(set, config);
  const int views[][2] = {{0, 2}, {1, 0}, {2, 3}, {0, 1}};
  for (const auto& [c, i] : views) {
    const StepStats g = pair.gpu->step_view(c, i), h = pair.cpu.step_view(c, i);
    EXPECT_LT(relative(g.loss, h.loss), 1e-4) << g.loss << " vs " << h.loss;
  }
  const model::Model gpu = pair.gpu->host_model();
  ASSERT_EQ(gpu.camera_poses.size(), set.cameras.size());
  for (const auto& [name, pose] : pair.cpu.model().camera_poses) {
    const model::CameraPose& other = gpu.camera_poses.at(name);
    for (int k = 0; k < 3; ++k) {
      // One Adam step moves a parameter by about its rate: the two agree to a small part of it.
      EXPECT_NEAR(other.rotation[k], pose.rotation[k], 0.05 * config.lr_camera_pose) << name;
      EXPECT_NEAR(other.translation[k], pose.translation[k],
                  0.05 * config.lr_camera_pose * set.scene_extent)
          << name;
    }
  }
}

// Clock refinement from the first step (camera 1 half a frame late, its clock refined; cameras
// 0 and 2 anchor the scene's): both devices take the same d loss / d t (the device's per-block
// sums of model::slice_row_time_vjp against the CPU's) and step the correction alike, the views
// then drawn at the moved time.
TEST(CudaStep, ClockRefinementMatchesTheCpu) {
  RETIMEGS_REQUIRE_GPU();
  const TrainingSet set = flow_scene({0, 0.5, 0});
  TrainConfig config = tiny_config(200);
  config.refine_clocks = true;
  config.clock_refine_start = 0;
  Pair pair(set, config);
  const int views[][2] = {{1, 2}, {0, 1}, {1, 0}, {1, 3}};
  for (const auto& [c, i] : views) {
    const StepStats g = pair.gpu->step_view(c, i), h = pair.cpu.step_view(c, i);
    EXPECT_LT(relative(g.loss, h.loss), 1e-4) << g.loss << " vs " << h.loss;
  }
  const model::Model gpu = pair.gpu->host_model();
  ASSERT_EQ(gpu.camera_clocks.size(), 1u);
  for (const auto& [name, delta] : pair.cpu.model().camera_clocks) {
    EXPECT_NE(delta, 0.0) << name;
    EXPECT_NEAR(gpu.camera_clocks.at(name), delta, 0.05 * config.lr_time_offset) << name;
  }
}

// Over random backgrounds, with the tiny scene's masks (the target's background pixels take the
// step's colour as the camera sees it) and without (the target stays the image): both devices
// composite the renders over the same colour, so their first steps' losses agree, and differ
// from a step over black.
TEST(CudaStep, RandomBackgroundStepMatchesTheCpu) {
  RETIMEGS_REQUIRE_GPU();
  const TrainingSet masked = flow_scene();
  TrainingSet unmasked = masked;
  for (auto& camera : unmasked.masks) std::fill(camera.begin(), camera.end(), std::nullopt);
  TrainConfig random = tiny_config(200), black = random;
  random.random_background = true;
  black.random_background = false;
  const int views[][2] = {{0, 0}, {1, 2}};
  for (const TrainingSet* set : {&masked, static_cast<const TrainingSet*>(&unmasked)})
    for (const auto& [c, i] : views) {
      SCOPED_TRACE(
          fmt::format("view camera {} frame {}, {}", c, i, set == &masked ? "masked" : "unmasked"));
      Pair pair(*set, random);
      const StepStats g = pair.gpu->step_view(c, i), h = pair.cpu.step_view(c, i);
      EXPECT_LT(relative(g.image_loss, h.image_loss), 1e-4)
          << g.image_loss << " vs " << h.image_loss;
      EXPECT_LT(relative(g.loss, h.loss), 1e-4) << g.loss << " vs " << h.loss;
      EXPECT_NEAR(g.psnr, h.psnr, 1e-3);
      Pair over_black(*set, black);
      EXPECT_GT(relative(over_black.gpu->step_view(c, i).image_loss, g.image_loss), 1e-2);
    }
}

// After one step from the same parameters, every optimised value moved as the CPU's did: the same
// rows and, but for gradients within rounding of zero, the same direction and size.
TEST(CudaStep, FirstStepUpdateMatchesTheCpu) {
  RETIMEGS_REQUIRE_GPU();
  const TrainingSet set = flow_scene();
  Pair pair(set, tiny_config(200));
  // Initialisation gives round footprints, whose rotation gradient is zero but for rounding: made
  // elongated, each rotation has a gradient of its own, which the devices must agree on.
  const model::Primitives before = [&] {
    model::Primitives p = pair.cpu.model().primitives;
    for (std::size_t i = 0; i < p.size(); ++i) {
      p.log_scale[3 * i] += 0.5f;
      p.log_scale[3 * i + 2] -= 0.5f;
    }
    return p;
  }();
  pair.cpu.initialize(before);
  pair.gpu->initialize(before);
  ASSERT_EQ(pair.cpu.model().primitives.mu, before.mu) << "the rows keep their order";
  pair.gpu->step_view(1, 2);
  pair.cpu.step_view(1, 2);
  const model::Primitives g = pair.gpu->host_model().primitives, &h = pair.cpu.model().primitives;
  ASSERT_EQ(g.size(), h.size());
  const auto fields_g = g.fields(), fields_h = h.fields(), fields_0 = before.fields();
  // Per field, the values that disagree by kind, for a failure message that points at the cause.
  std::size_t moved = 0, agree = 0;
  std::string disagreements;
  for (int f = 0; f < model::Primitives::kFieldCount; ++f) {
    const std::vector<float>&a = *fields_g[f].values, &b = *fields_h[f].values,
          &o = *fields_0[f].values;
    std::size_t field_moved = 0, only_gpu = 0, only_cpu = 0, opposite = 0, size = 0;
    std::string example;
    for (std::size_t k = 0; k < b.size(); ++k) {
      ASSERT_TRUE(std::isfinite(a[k])) << fields_g[f].name << " value " << k;
      const double dg = double(a[k]) - o[k], dh = double(b[k]) - o[k];
      if (dh == 0 && dg == 0) continue;
      ++field_moved;
      if (std::abs(dg - dh) <= 1e-2 * std::abs(dh) + 1e-7 * (1 + std::abs(o[k]))) continue;
      if (dh == 0)
        ++only_gpu;
      else if (dg == 0)
        ++only_cpu;
      else if ((dg > 0) != (dh > 0))
        ++opposite;
      else
        ++size;
      if (example.empty())
        example = fmt::format(" (value {}: {} -> gpu {}, cpu {})", k, o[k], a[k], b[k]);
    }
    const std::size_t bad = only_gpu + only_cpu + opposite + size;
    moved += field_moved, agree += field_moved - bad;
    if (bad)
      disagreements += fmt::format(
          "\n  {}: {} of {} moved values disagree: {} moved on the GPU only, {} on the CPU only, "
          "{} "
          "in opposite directions, {} by different amounts{}",
          fields_g[f].name, bad, field_moved, only_gpu, only_cpu, opposite, size, example);
  }
  EXPECT_GT(moved, 1000u);
  EXPECT_GE(double(agree), 0.98 * double(moved))
      << agree << " of " << moved << " values agree" << disagreements;
}

// Two CUDA runs from the same state over the same views agree (the rasteriser's backward sums in
// the order its atomics land: not bit for bit). The milestones stay absolute, so that no
// relocation, whose draws depend on which rows are dead, runs within the 20 steps.
TEST(CudaStep, TwoRunsAgree) {
  RETIMEGS_REQUIRE_GPU();
  const TrainingSet set = flow_scene();
  TrainConfig config = tiny_config(200);
  config.scale_schedule = false;
  CpuStep seed(set, config);
  seed.initialize();
  std::unique_ptr<TrainingStep> a = make_step(set, config, cuda::Device::kCuda);
  std::unique_ptr<TrainingStep> b = make_step(set, config, cuda::Device::kCuda);
  a->initialize(seed.model().primitives);
  b->initialize(seed.model().primitives);
  const int cameras = int(set.cameras.size()), frames = int(set.frames.size());
  for (int s = 0; s < 20; ++s) {
    const int c = s % cameras, i = (s / cameras) % frames;
    const StepStats x = a->step_view(c, i), y = b->step_view(c, i);
    EXPECT_LT(relative(x.loss, y.loss), 1e-3) << "step " << s + 1;
  }
}

// Held-out PSNR: a model's renders (CPU renderer) halfway between consecutive training frames,
// from every camera, against the ball drawn at that time, over all of them.
double held_out_psnr(const model::Model& m, const TrainingSet& set) {
  double squared_error = 0;
  std::size_t count = 0;
  render::RenderOptions options;
  options.near_plane = set.near_plane;
  const float black[3] = {0, 0, 0};
  for (const int camera : set.cameras)
    for (int i = 0; i + 1 < set.grid.count; ++i) {
      const Camera& cam = set.scene.cameras[camera];
      const double t = set.grid.at(i) + 0.5 * set.grid.step;
      const model::TimeSlice s = model::slice(m.primitives, m.config, m.grid, t, cam, {});
      const Image image = render::rasterize_forward(s.gaussians, cam, black, options).blend.image;
      const Image truth = test::tiny_ball_image(cam, t);
      for (std::size_t k = 0; k < image.data.size(); ++k)
        squared_error += double(image.data[k] - truth.data[k]) * (image.data[k] - truth.data[k]);
      count += image.data.size();
    }
  return psnr_from_squared_error(squared_error, count);
}

// The whole recipe (triple rendering, flow, relocation, growth, stretching, SH schedule) for 2 000
// steps on each device: the models score alike on held-out times. One run's held-out PSNR moves
// with its seed (CPU, seeds 0 to 3: 46.00, 46.49, 46.33, 46.06 dB), and the GPU's rounding moves
// it as a seed does, so the mean over three seeds is compared.
TEST(CudaStep, TrainsAsWellAsTheCpu) {
  RETIMEGS_REQUIRE_GPU();
  const TrainingSet set = flow_scene();
  constexpr int kSeeds = 3;
  double g = 0, h = 0;
  for (int seed = 0; seed < kSeeds; ++seed) {
    TrainConfig config = tiny_config(2000);
    config.seed = std::uint64_t(seed);
    Pair pair(set, config);
    for (int s = 0; s < config.iters; ++s) {
      pair.gpu->step();
      pair.cpu.step();
    }
    pair.gpu->finish();
    pair.cpu.finish();
    const double gs = held_out_psnr(pair.gpu->host_model(), set);
    const double hs = held_out_psnr(pair.cpu.model(), set);
    std::printf("seed %d: held-out PSNR after %d steps: cuda %.3f dB, cpu %.3f dB\n", seed,
                config.iters, gs, hs);
    g += gs / kSeeds, h += hs / kSeeds;
  }
  EXPECT_GT(h, 40) << "the CPU runs learn the scene";
  EXPECT_NEAR(g, h, 0.3) << "mean held-out PSNR over " << kSeeds << " seeds";
}

// Relocation and growth run on the device rows at the CPU's iterations, with the same counts
// added, and training goes on from them.
TEST(CudaStep, ReshapesAtTheCpusIterations) {
  RETIMEGS_REQUIRE_GPU();
  const TrainingSet set = flow_scene();
  TrainConfig config = tiny_config(200);  // scaled: relocation every step from step 5
  config.cap = 6000;
  Pair pair(set, config);
  std::size_t added = 0;
  for (int s = 0; s < 30; ++s) {
    const StepStats g = pair.gpu->step(), h = pair.cpu.step();
    EXPECT_EQ(g.added, h.added) << "step " << s + 1;
    EXPECT_EQ(g.primitives, h.primitives) << "step " << s + 1;
    ASSERT_TRUE(std::isfinite(g.loss)) << "step " << s + 1;
    added += g.added;
  }
  EXPECT_GT(added, 0u);
  EXPECT_EQ(pair.gpu->host_model().primitives.size(), pair.gpu->primitive_count());
}

// Relocation and growth on the device rows, decided on the host from three of their fields, leave
// the rows the CPU's do, bit for bit and in the same order, from the same state: every learning
// rate zero, so that the step before them leaves the parameters as they were, and one row in
// seven dead.
TEST(CudaStep, RelocationAndGrowthLeaveTheCpusRows) {
  RETIMEGS_REQUIRE_GPU();
  const TrainingSet set = flow_scene();
  TrainConfig config = tiny_config(200);
  config.scale_schedule = false;
  config.relocate_start = 0, config.relocate_every = 1;  // at the first step
  for (double* lr :
       {&config.lr_means, &config.lr_means_final, &config.lr_velocity, &config.lr_scales,
        &config.lr_quats, &config.lr_quat_rate, &config.lr_opacities, &config.lr_sh0,
        &config.lr_temporal_center, &config.lr_temporal_scale, &config.lr_camera_color})
    *lr = 0;
  Pair pair(set, config);
  model::Primitives start = pair.cpu.model().primitives;
  for (std::size_t i = 0; i < start.size(); i += 7) start.opacity_logit[i] = -12;
  pair.cpu.initialize(start);
  pair.gpu->initialize(start);
  const StepStats g = pair.gpu->step_view(1, 2), h = pair.cpu.step_view(1, 2);
  EXPECT_GT(h.relocated, 0u);
  EXPECT_GT(h.added, 0u);
  EXPECT_EQ(g.relocated, h.relocated);
  EXPECT_EQ(g.added, h.added);
  const model::Primitives a = pair.gpu->host_model().primitives, &b = pair.cpu.model().primitives;
  ASSERT_EQ(a.size(), b.size());
  const auto fields_a = a.fields(), fields_b = b.fields();
  for (int f = 0; f < model::Primitives::kFieldCount; ++f)
    EXPECT_EQ(*fields_a[f].values, *fields_b[f].values) << fields_a[f].name;
  for (int s = 0; s < 3; ++s) ASSERT_TRUE(std::isfinite(pair.gpu->step().loss)) << s;
}

// A checkpoint written on one device resumes on the other: the model read back is the one
// written, bit for bit, and training continues from it.
TEST(CudaStep, CheckpointsResumeOnEitherDevice) {
  RETIMEGS_REQUIRE_GPU();
  test::TempDir dir;
  const TrainingSet set = flow_scene();
  const TrainConfig config = tiny_config(200);
  Pair pair(set, config);
  for (int s = 0; s < 15; ++s) pair.gpu->step();
  pair.gpu->save_checkpoint(dir / "gpu");
  CpuStep cpu(set, config);
  cpu.load_checkpoint(dir / "gpu");
  const model::Model written = pair.gpu->host_model();
  EXPECT_EQ(cpu.iteration(), 15);
  EXPECT_EQ(cpu.model().primitives.mu, written.primitives.mu);
  EXPECT_EQ(cpu.model().primitives.sh, written.primitives.sh);
  for (int s = 0; s < 10; ++s) ASSERT_TRUE(std::isfinite(cpu.step().loss));
  cpu.save_checkpoint(dir / "cpu");
  std::unique_ptr<TrainingStep> gpu = make_step(set, config, cuda::Device::kCuda);
  gpu->load_checkpoint(dir / "cpu");
  EXPECT_EQ(gpu->iteration(), 25);
  EXPECT_EQ(gpu->host_model().primitives.opacity_logit, cpu.model().primitives.opacity_logit);
  for (int s = 0; s < 10; ++s) ASSERT_TRUE(std::isfinite(gpu->step().loss));
  const std::string note = gpu->finish();
  EXPECT_NE(note.find("final prune"), std::string::npos) << note;
}

}  // namespace
}  // namespace retimegs::train
