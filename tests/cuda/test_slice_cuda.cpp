// cuda::slice, slice_backward, shade and shade_backward against the CPU's model::slice (float),
// for random primitives: Retime (Catmull-Rom and linear) and STGS, SH degrees 0..3, windows open
// and closed, at training times, in between and just outside the clip, every group, compensated
// or not, with and without flow features, row lists and shaded colours.
//
// Both devices run the same per-row formulas (model/slice_formulas.hpp) in the same order, so:
//   - the batch's rows (primitive_from_gaussian) are equal exactly: the cut (σ · σ_τ against
//     min_opacity, σ_τ > 0) and the group test compare values that differ by a few ulps at most,
//     and the inputs keep them far from those thresholds (the windows' edges lie on the grid,
//     never 3.4 to 3.6 frames from a tested time, where a window's sigmoid would underflow);
//   - log_scales are copies (equal exactly), and so is a colour copied from shaded;
//   - the other values differ by rounding only: nvcc contracts a * b + c into FMA, g++ (model is
//     built without contraction) does not, and the device's expf is within 2 ulps of glibc's. Each
//     value is within kRoundings float epsilons of its field's largest magnitude in the batch
//     (at least 1): 32 for opacities, σ_τ, means and quaternions (a few operations each; the
//     STGS σ_τ = exp(-d²) amplifies the error of d² by d², which the value's e^{-d²} outweighs),
//     128 for the SH colours (sums of up to 16 contracted products of a basis built from a
//     normalised direction) and the flow features (differences of pixel coordinates, so the
//     image's coordinate scale, not the flows', sets their rounding).
// The colours' SH sums are kept away from the clamp at 0 (each channel's DC term either makes
// it at least 0.16 or at most -0.29), so that both devices take the same branch.
// Gradients: the same chain rule per row, no atomics (each primitive is in a batch once), rounded
// differently: within 1e-4 of the CPU's value plus 1e-5 of the field's largest magnitude (sums
// of terms that cancel). Gradients are accumulated onto a random base, so += is checked too.
// Every GPU output is poisoned (0xff bytes: NaN floats, -1 integers) before each call.
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "cuda/random_arrays.hpp"
#include "cuda/require_gpu.hpp"
#include "retimegs/core/camera.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/cuda/slice.hpp"
#include "retimegs/model/slice.hpp"

namespace retimegs::cuda {
namespace {

using model::Group;
using model::Representation;
using model::TrajectoryKind;

constexpr unsigned char kPoison = 0xff;
constexpr double kRoundings = 32, kShRoundings = 128;
constexpr double kGradRel = 1e-4, kGradAbs = 1e-5;

const model::TimeGrid kGrid{0.0, 2.0, 5};  // training times 0, 2, 4, 6, 8

Camera test_camera() {
  Camera c;
  c.name = "c";
  c.width = 64, c.height = 48;
  c.fx = 60, c.fy = 58, c.cx = 32.3, c.cy = 23.8;
  c.world_to_camera = look_at({0.4, -0.3, -5.0}, {0, 0, 0}, {0, -1, 0});
  return c;
}

// Whether channel c of row i has its SH sum clamped to 0 (see the top of the file).
bool clamped_channel(int i, int c) {
  return (i + c) % 4 == 0;
}

// n primitives near the origin, in front of the camera (camera z in [1.5, 8.5]; the flow
// features' control points too, far from kFlowNearZ). Retime: each on an interval of the grid,
// some stretched over 2 or 3 intervals, the first and last intervals' outer edges open.
model::Primitives random_primitives(Representation representation, int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> u(-1, 1);
  const bool stgs = representation == Representation::kStgs;
  model::Primitives p;
  p.resize(n);
  const float step = float(kGrid.step);
  for (int i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) p.mu[3 * i + a] = 0.9f * u(rng);
    // STGS moves by b1 Δ + b2 Δ² + b3 Δ³ with |Δ| up to 8 frames: smaller b2, b3.
    const float motion[3] = {0.15f, stgs ? 0.01f : 0.15f, stgs ? 0.001f : 0.15f};
    for (int j = 0; j < 3; ++j)
      for (int a = 0; a < 3; ++a) p.velocity[9 * i + 3 * j + a] = motion[j] * u(rng);
    for (int a = 0; a < 3; ++a) p.log_scale[3 * i + a] = std::log(0.05f + 0.02f * u(rng));
    for (int a = 0; a < 4; ++a) p.q0[4 * i + a] = u(rng) + (a == 0 ? 1.5f : 0.0f);
    for (int a = 0; a < 4; ++a) p.q1[4 * i + a] = 0.2f * u(rng);
    for (int k = 0; k < model::kMaxShCoeffs; ++k)
      for (int c = 0; c < 3; ++c) {
        float h = 0.03f * u(rng);
        if (k == 0) h = clamped_channel(i, c) ? -4.5f + 0.5f * u(rng) : 0.5f + 0.5f * u(rng);
        p.sh[model::Primitives::kShWidth * i + 3 * k + c] = h;
      }
    p.opacity_logit[i] = 3.0f * u(rng);
    if (stgs) {
      p.mu_tau[i] = float(kGrid.first + (kGrid.last() - kGrid.first) * (0.5 + 0.5 * u(rng)));
      p.temporal_log_scale[i] = std::log(1.5f + 0.5f * u(rng));
      p.tau_l[i] = p.tau_r[i] = step / 2;
    } else {
      const int interval = i % (kGrid.count - 1);
      p.mu_tau[i] = float(kGrid.first) + step * (float(interval) + 0.5f);
      p.tau_l[i] = p.tau_r[i] = step / 2;
      if (i % 5 == 1) p.tau_l[i] += step;      // stretched to the left
      if (i % 5 == 2) p.tau_r[i] += 2 * step;  // to the right (some past the clip's end)
      p.temporal_log_scale[i] = 0;
    }
  }
  return p;
}

struct ModelCase {
  std::string name;
  model::ModelConfig config;
};

std::vector<ModelCase> model_cases() {
  std::vector<ModelCase> out;
  model::ModelConfig c;
  c.sh_degree = 3;
  out.push_back({"retime catmull-rom sh3", c});
  c.sh_degree = 0;
  out.push_back({"retime catmull-rom sh0", c});
  c.trajectory = TrajectoryKind::kLinear, c.sh_degree = 1;
  out.push_back({"retime linear sh1", c});
  c = {};
  c.representation = Representation::kStgs, c.sh_degree = 2;
  out.push_back({"stgs sh2", c});
  return out;
}

double magnitude(const std::vector<float>& v) {
  double m = 1;
  for (const float x : v) m = std::max(m, std::abs(double(x)));
  return m;
}

// Every value of gpu within roundings · FLT_EPSILON · (the largest |cpu|, at least 1) of cpu.
void expect_rounding_close(const char* what, const std::vector<float>& gpu,
                           const std::vector<float>& cpu, double roundings) {
  ASSERT_EQ(gpu.size(), cpu.size()) << what;
  const double tolerance = roundings * FLT_EPSILON * magnitude(cpu);
  for (std::size_t k = 0; k < cpu.size(); ++k)
    ASSERT_NEAR(gpu[k], cpu[k], tolerance) << what << " value " << k;
}

// Every gradient within kGradRel |cpu| + kGradAbs · (the field's largest |cpu|) of cpu.
void expect_grad_close(const char* what, const std::vector<float>& gpu,
                       const std::vector<float>& cpu) {
  ASSERT_EQ(gpu.size(), cpu.size()) << what;
  const double floor = kGradAbs * magnitude(cpu);
  for (std::size_t k = 0; k < cpu.size(); ++k)
    ASSERT_NEAR(gpu[k], cpu[k], kGradRel * std::abs(cpu[k]) + floor) << what << " value " << k;
}

void poison(DeviceBuffer<float>& b, std::size_t n) {
  b.resize(n);
  b.fill_bytes(kPoison);
}

void upload_grads(const model::PrimitiveGrads& host, DevicePrimitiveGrads& device) {
  device.v_mu.upload(host.v_mu);
  device.v_velocity.upload(host.v_velocity);
  device.v_log_scale.upload(host.v_log_scale);
  device.v_q0.upload(host.v_q0);
  device.v_q1.upload(host.v_q1);
  device.v_sh.upload(host.v_sh);
  device.v_opacity_logit.upload(host.v_opacity_logit);
  device.v_mu_tau.upload(host.v_mu_tau);
  device.v_temporal_log_scale.upload(host.v_temporal_log_scale);
}

// A random base onto which the backward passes accumulate.
model::PrimitiveGrads random_grads(std::size_t n, std::uint64_t seed) {
  model::PrimitiveGrads g(n);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> u(-1, 1);
  for (auto* field : {&g.v_mu, &g.v_velocity, &g.v_log_scale, &g.v_q0, &g.v_q1, &g.v_sh,
                      &g.v_opacity_logit, &g.v_mu_tau, &g.v_temporal_log_scale})
    for (float& x : *field) x = u(rng);
  return g;
}

// The renderer's gradient of an m-row batch: random, every 7th row all zero (skipped by both).
GaussianGrads random_gaussian_grads(std::size_t m, int channels, std::uint64_t seed) {
  GaussianGrads g(m, channels);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> u(-1, 1);
  for (std::size_t row = 0; row < m; ++row) {
    if (row % 7 == 3) continue;
    for (int a = 0; a < 3; ++a) g.v_means[3 * row + a] = u(rng);
    for (int a = 0; a < 3; ++a) g.v_log_scales[3 * row + a] = u(rng);
    for (int a = 0; a < 4; ++a) g.v_quats[4 * row + a] = u(rng);
    g.v_opacities[row] = u(rng);
    for (int c = 0; c < channels; ++c) g.v_features[channels * row + c] = u(rng);
  }
  return g;
}

void upload_gaussian_grads(const GaussianGrads& host, DeviceGaussianGrads& device) {
  device.channels = host.channels;
  device.v_means.upload(host.v_means.data(), host.v_means.size());
  device.v_log_scales.upload(host.v_log_scales.data(), host.v_log_scales.size());
  device.v_quats.upload(host.v_quats.data(), host.v_quats.size());
  device.v_opacities.upload(host.v_opacities.data(), host.v_opacities.size());
  device.v_features.upload(host.v_features.data(), host.v_features.size());
}

struct Case {
  double t;
  Group group;
  bool compensate, flow_features, row_list, shaded;
  double min_opacity;

  std::string name() const {
    const char* groups[] = {"all", "left", "right"};
    return "t=" + std::to_string(t) + " group=" + groups[int(group)] +
           (compensate ? " compensate" : "") + (flow_features ? " flow" : "") +
           (row_list ? " rows" : "") + (shaded ? " shaded" : "") +
           " min_opacity=" + std::to_string(min_opacity);
  }
};

// One case: forward and backward on both devices, compared as the top of the file says.
void check_case(const ModelCase& setup, const model::Primitives& primitives,
                const DevicePrimitives& device_primitives, const Case& c, std::uint64_t seed) {
  SCOPED_TRACE(setup.name + " " + c.name());
  const model::ModelConfig& config = setup.config;
  const Camera camera = test_camera();
  const std::size_t n = primitives.size();

  // The row list: every primitive but those with i % 3 == 1 (ascending).
  std::vector<std::int32_t> rows;
  for (std::size_t i = 0; i < n; ++i)
    if (!c.row_list || i % 3 != 1) rows.push_back(std::int32_t(i));
  DeviceBuffer<std::int32_t> device_rows;
  device_rows.upload(rows);
  const std::int32_t* rows_ptr = c.row_list ? device_rows.data() : nullptr;

  model::SliceOptions options;
  options.group = c.group;
  options.compensate = c.compensate;
  options.flow_features = c.flow_features;
  options.min_opacity = c.min_opacity;
  options.rows = c.row_list ? &rows : nullptr;
  DeviceSliceOptions device_options;
  device_options.group = c.group;
  device_options.compensate = c.compensate;
  device_options.flow_features = c.flow_features;
  device_options.min_opacity = c.min_opacity;
  device_options.rows = rows_ptr;
  device_options.row_count = c.row_list ? rows.size() : 0;

  // Shaded colours (on the row list's rows, or on every row).
  model::Shaded cpu_shaded;
  DeviceShaded gpu_shaded;
  if (c.shaded) {
    model::shade(primitives, config, kGrid, c.t, camera, rows, cpu_shaded);
    poison(gpu_shaded.rgb, 3 * n);
    poison(gpu_shaded.v_rgb, 3 * n);
    shade(device_primitives, config, kGrid, c.t, camera, rows_ptr, rows.size(), gpu_shaded);
    const std::vector<float> rgb = gpu_shaded.rgb.download(), v_rgb = gpu_shaded.v_rgb.download();
    std::vector<float> gpu_rows, cpu_rows;
    for (const std::int32_t i : rows)
      for (int a = 0; a < 3; ++a) {
        gpu_rows.push_back(rgb[3 * i + a]);
        cpu_rows.push_back(cpu_shaded.rgb[3 * i + a]);
        ASSERT_EQ(v_rgb[3 * i + a], 0.0f) << "shaded v_rgb of row " << i;
      }
    expect_rounding_close("shaded rgb", gpu_rows, cpu_rows, kShRoundings);
  }

  // Forward.
  model::TimeSlice cpu;
  model::slice(primitives, config, kGrid, c.t, camera, options, cpu,
               c.shaded ? &cpu_shaded : nullptr);
  const std::size_t m = cpu.primitive_from_gaussian.size();
  const int channels = cpu.gaussians.channels;
  DeviceTimeSlice gpu;
  poison(gpu.gaussians.means, 3 * m);
  poison(gpu.gaussians.log_scales, 3 * m);
  poison(gpu.gaussians.quats, 4 * m);
  poison(gpu.gaussians.opacities, m);
  poison(gpu.gaussians.features, std::size_t(channels) * m);
  poison(gpu.temporal, m);
  gpu.primitive_from_gaussian.resize(m);
  gpu.primitive_from_gaussian.fill_bytes(kPoison);
  slice(device_primitives, config, kGrid, c.t, camera, device_options, gpu,
        c.shaded ? &gpu_shaded : nullptr);
  ASSERT_EQ(gpu.size(), m);
  ASSERT_EQ(gpu.gaussians.channels, channels);
  ASSERT_EQ(gpu.primitive_from_gaussian.download(), cpu.primitive_from_gaussian);
  const Gaussians g = gpu.gaussians.download();
  ASSERT_EQ(g.log_scales, cpu.gaussians.log_scales);
  expect_rounding_close("temporal", gpu.temporal.download(), cpu.temporal, kRoundings);
  expect_rounding_close("opacities", g.opacities, cpu.gaussians.opacities, kRoundings);
  expect_rounding_close("means", g.means, cpu.gaussians.means, kRoundings);
  expect_rounding_close("quats", g.quats, cpu.gaussians.quats, kRoundings);
  std::vector<float> gpu_rgb, cpu_rgb, gpu_flow, cpu_flow;
  const std::vector<float> shaded_rgb = c.shaded ? gpu_shaded.rgb.download() : std::vector<float>{};
  for (std::size_t row = 0; row < m; ++row)
    for (int k = 0; k < channels; ++k) {
      const float value = g.features[channels * row + k],
                  expected = cpu.gaussians.features[channels * row + k];
      if (k < 3 && c.shaded) {  // copied from the GPU's shaded colours
        ASSERT_EQ(value, shaded_rgb[3 * std::size_t(cpu.primitive_from_gaussian[row]) + k])
            << "row " << row;
      }
      (k < 3 ? gpu_rgb : gpu_flow).push_back(value);
      (k < 3 ? cpu_rgb : cpu_flow).push_back(expected);
    }
  expect_rounding_close("rgb", gpu_rgb, cpu_rgb, kShRoundings);
  if (c.flow_features) {
    // Rounding on the scale of the pixel coordinates (see the top of the file).
    const double scale = camera.width + camera.height;
    for (std::size_t k = 0; k < cpu_flow.size(); ++k)
      ASSERT_NEAR(gpu_flow[k], cpu_flow[k], kShRoundings * FLT_EPSILON * scale)
          << "flow value " << k;
  }

  // Backward.
  const GaussianGrads v_gaussians = random_gaussian_grads(m, channels, seed);
  const model::PrimitiveGrads base = random_grads(n, seed + 1);
  model::PrimitiveGrads cpu_grads = base;
  model::slice_backward(primitives, config, kGrid, c.t, camera, options, cpu, v_gaussians,
                        cpu_grads, c.shaded ? &cpu_shaded : nullptr);
  DevicePrimitiveGrads gpu_grads;
  upload_grads(base, gpu_grads);
  DeviceGaussianGrads device_v_gaussians;
  upload_gaussian_grads(v_gaussians, device_v_gaussians);
  slice_backward(device_primitives, config, kGrid, c.t, camera, device_options, gpu,
                 device_v_gaussians, gpu_grads, c.shaded ? &gpu_shaded : nullptr);
  if (c.shaded) {
    // 0 + the colours' gradients: exact on both.
    const std::vector<float> v_rgb = gpu_shaded.v_rgb.download();
    for (const std::int32_t i : rows)
      for (int a = 0; a < 3; ++a)
        ASSERT_EQ(v_rgb[3 * i + a], cpu_shaded.v_rgb[3 * i + a]) << "shaded v_rgb of row " << i;
    model::shade_backward(primitives, config, kGrid, c.t, camera, rows, cpu_shaded, cpu_grads);
    shade_backward(device_primitives, config, kGrid, c.t, camera, rows_ptr, rows.size(), gpu_shaded,
                   gpu_grads);
  }
  // d loss / d t: the device's per-block sums against the CPU's chunks, both in double over the
  // same float rows (the SH's rounding on the scale of the largest row).
  const double cpu_time =
      model::slice_time_vjp(primitives, config, kGrid, c.t, camera, options, cpu, v_gaussians);
  DeviceBuffer<double> time_sum(1), partials;
  time_sum.fill_bytes(0);
  slice_time_sum(device_primitives, config, kGrid, c.t, camera, device_options, gpu,
                 device_v_gaussians, time_sum.data(), partials);
  const double gpu_time = time_sum.download()[0];
  // The rows' magnitudes bound what their float rounding can move the sum by.
  model::SliceParams<float> params = model::slice_params<float>(
      config, kGrid, c.t, camera, Group::kAll, c.compensate, c.flow_features, c.min_opacity);
  params.channels = channels;
  const model::GaussianGradArrays<float> vg = {
      v_gaussians.v_means.data(), v_gaussians.v_log_scales.data(), v_gaussians.v_quats.data(),
      v_gaussians.v_opacities.data(), v_gaussians.v_features.data()};
  double magnitude = 0;
  float v_sh[model::Primitives::kShWidth];
  for (std::size_t row = 0; row < m; ++row)
    magnitude += std::abs(
        model::slice_row_time_vjp(params, model::primitive_arrays<float>(primitives),
                                  std::size_t(cpu.primitive_from_gaussian[row]), vg, row, v_sh));
  EXPECT_NEAR(gpu_time, cpu_time, kShRoundings * FLT_EPSILON * magnitude + 1e-9) << "d loss / d t";

  model::PrimitiveGrads out;
  gpu_grads.download(out);
  expect_grad_close("v_mu", out.v_mu, cpu_grads.v_mu);
  expect_grad_close("v_velocity", out.v_velocity, cpu_grads.v_velocity);
  expect_grad_close("v_log_scale", out.v_log_scale, cpu_grads.v_log_scale);
  expect_grad_close("v_q0", out.v_q0, cpu_grads.v_q0);
  expect_grad_close("v_q1", out.v_q1, cpu_grads.v_q1);
  expect_grad_close("v_sh", out.v_sh, cpu_grads.v_sh);
  expect_grad_close("v_opacity_logit", out.v_opacity_logit, cpu_grads.v_opacity_logit);
  expect_grad_close("v_mu_tau", out.v_mu_tau, cpu_grads.v_mu_tau);
  expect_grad_close("v_temporal_log_scale", out.v_temporal_log_scale,
                    cpu_grads.v_temporal_log_scale);
}

TEST(SliceCuda, ForwardAndBackwardMatchTheCpu) {
  RETIMEGS_REQUIRE_GPU();
  constexpr int kPrimitives = 3000;  // several blocks of 256 threads
  // Training times, in between, and just outside the clip (linear continuation).
  const double times[] = {0.0, 2.0, 4.0, 6.0, 8.0, 1.0, 3.3, 5.7, -0.5, 8.5};
  std::uint64_t seed = 100;
  for (const ModelCase& setup : model_cases()) {
    const model::Primitives primitives =
        random_primitives(setup.config.representation, kPrimitives, seed++);
    DevicePrimitives device_primitives;
    device_primitives.upload(primitives);
    for (const double t : times) {
      std::vector<Group> groups = {Group::kAll};
      const bool training_time = t >= 0 && t <= 8 && std::fmod(t, 2.0) == 0;
      if (setup.config.representation == Representation::kRetime && training_time) {
        if (t > 0) groups.push_back(Group::kLeft);
        if (t < 8) groups.push_back(Group::kRight);
      }
      for (const Group group : groups)
        for (int variant = 0; variant < 8; ++variant) {
          Case c;
          c.t = t;
          c.group = group;
          c.flow_features = variant & 1;
          c.row_list = variant & 2;
          c.shaded = variant & 4;
          // Compensated in group renders (as triple rendering draws them), and in some others.
          c.compensate = group != Group::kAll || variant == 5;
          c.min_opacity = variant == 3 || variant == 6 ? 0.0 : 1.0 / 255.0;
          check_case(setup, primitives, device_primitives, c, seed++);
          if (testing::Test::HasFatalFailure()) return;
        }
    }
  }
}

// The message of the Error that f throws ("" when it throws none).
template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(SliceCuda, ThrowsAsTheCpu) {
  RETIMEGS_REQUIRE_GPU();
  const Camera camera = test_camera();
  for (const Representation representation : {Representation::kRetime, Representation::kStgs}) {
    model::ModelConfig config;
    config.representation = representation;
    const model::Primitives primitives = random_primitives(representation, 40, 7);
    DevicePrimitives device_primitives;
    device_primitives.upload(primitives);
    struct Bad {
      double t;
      Group group;
      std::vector<std::int32_t> rows;  // empty: no row list
    };
    const std::vector<Bad> bad = {
        {3.0, Group::kLeft, {}},   // not a training time
        {0.0, Group::kLeft, {}},   // no interval before the first
        {8.0, Group::kRight, {}},  // none after the last
        {2.0, Group::kLeft, {}},   // STGS: no groups (Retime: fine)
        {std::numeric_limits<double>::quiet_NaN(), Group::kAll, {}},
        {3.0, Group::kAll, {0, 5, 5, 9}},  // not ascending
        {3.0, Group::kAll, {1, 2, 40}},    // past the primitives
        {3.0, Group::kAll, {-1, 2}},
    };
    for (const Bad& b : bad) {
      SCOPED_TRACE(testing::Message()
                   << "t=" << b.t << " group=" << int(b.group) << " rows=" << b.rows.size());
      model::SliceOptions options;
      options.group = b.group;
      options.rows = b.rows.empty() ? nullptr : &b.rows;
      DeviceBuffer<std::int32_t> rows;
      rows.upload(b.rows);
      DeviceSliceOptions device_options;
      device_options.group = b.group;
      device_options.rows = b.rows.empty() ? nullptr : rows.data();
      device_options.row_count = b.rows.size();
      const std::string cpu =
          error_of([&] { model::slice(primitives, config, kGrid, b.t, camera, options); });
      DeviceTimeSlice out;
      const std::string gpu = error_of(
          [&] { slice(device_primitives, config, kGrid, b.t, camera, device_options, out); });
      EXPECT_EQ(gpu, cpu);
    }
  }
}

TEST(SliceCuda, EmptyBatches) {
  RETIMEGS_REQUIRE_GPU();
  const Camera camera = test_camera();
  const model::ModelConfig config;
  const model::Primitives primitives = random_primitives(Representation::kRetime, 300, 9);
  DevicePrimitives device_primitives;
  device_primitives.upload(primitives);
  DeviceTimeSlice out;
  DeviceSliceOptions options;
  options.min_opacity = 2.0;  // above every opacity
  slice(device_primitives, config, kGrid, 3.0, camera, options, out);
  EXPECT_EQ(out.size(), 0u);
  EXPECT_EQ(out.gaussians.size(), 0u);
  DeviceBuffer<std::int32_t> rows;
  rows.upload(std::vector<std::int32_t>{0});
  options = {};
  options.rows = rows.data();
  options.row_count = 0;
  slice(device_primitives, config, kGrid, 3.0, camera, options, out);
  EXPECT_EQ(out.size(), 0u);
  DeviceGaussianGrads v_gaussians;
  DevicePrimitiveGrads grads;
  grads.resize_zero(primitives.size());
  slice_backward(device_primitives, config, kGrid, 3.0, camera, options, out, v_gaussians, grads);
  model::PrimitiveGrads host;
  grads.download(host);
  for (const float v : host.v_mu) ASSERT_EQ(v, 0.0f);
}

}  // namespace
}  // namespace retimegs::cuda
