// slice(t, camera) and its backward against central finite differences in double precision:
// temporal opacity, trajectory, rotation, SH colour, flow features, compensation, STGS, and the
// whole slice -> rasterise chain.
#include <algorithm>
#include <cmath>
#include <functional>
#include <random>

#include <gtest/gtest.h>

#include "retimegs/core/error.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/model/sh.hpp"
#include "retimegs/model/slice.hpp"
#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/render/reference.hpp"
#include "test_util.hpp"

namespace retimegs::model {
namespace {

using P = PrimitivesT<double>;
using G = PrimitiveGradsT<double>;

const TimeGrid kGrid{0.0, 2.0, 5};  // training times 0, 2, 4, 6, 8

Camera small_camera(int width = 24, int height = 20) {
  Camera cam;
  cam.name = "c";
  cam.width = width, cam.height = height;
  cam.fx = 22, cam.fy = 21, cam.cx = width / 2.0 + 0.3, cam.cy = height / 2.0 - 0.2;
  cam.world_to_camera = look_at({0.4, -0.3, -5.0}, {0, 0, 0}, {0, -1, 0});
  return cam;
}

// Primitives of every interval (μ_τ = 1, 3, 5, 7), one stretched over [2, 6], near the origin.
P random_primitives(Representation rep, unsigned seed, int n = 6) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  P p;
  p.resize(n);
  for (int i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) p.mu[3 * i + a] = 0.8 * u(rng);
    for (int k = 0; k < 9; ++k) p.velocity[9 * i + k] = 0.15 * u(rng);
    for (int a = 0; a < 3; ++a) p.log_scale[3 * i + a] = std::log(0.25 + 0.1 * u(rng));
    for (int a = 0; a < 4; ++a) p.q0[4 * i + a] = u(rng) + (a == 0 ? 1.5 : 0.0);
    for (int a = 0; a < 4; ++a) p.q1[4 * i + a] = 0.2 * u(rng);
    for (int k = 0; k < 48; ++k) p.sh[48 * i + k] = (k < 3 ? 0.8 : 0.2) * u(rng);
    p.opacity_logit[i] = 0.5 * u(rng);
    p.mu_tau[i] = 1.0 + 2.0 * (i % 4);
    p.tau_l[i] = p.tau_r[i] = 1.0;
    p.temporal_log_scale[i] = std::log(1.5 + 0.3 * u(rng));
  }
  if (n > 4) p.mu_tau[4] = 5.0, p.tau_l[4] = 3.0;  // stretched: support [2, 6]
  if (rep == Representation::kStgs)
    for (int i = 0; i < n; ++i) p.mu_tau[i] = 4.0 + 2.0 * u(rng);
  return p;
}

PrimitivesT<float> float_primitives(const P& source) {
  PrimitivesT<float> p;
  p.resize(source.size());
  for (int f = 0; f < P::kFieldCount; ++f)
    std::copy(source.fields()[f].values->begin(), source.fields()[f].values->end(),
              p.fields()[f].values->begin());
  return p;
}

// Every optimised scalar of the model, by name, for finite differences.
std::vector<std::pair<std::string, double*>> parameters(P& p, Representation rep, int sh_degree) {
  std::vector<std::pair<std::string, double*>> out;
  auto add = [&](const std::string& name, std::vector<double>& v, int width, int used) {
    for (std::size_t i = 0; i < v.size(); ++i)
      if (int(i % width) < used) out.push_back({name + "[" + std::to_string(i) + "]", &v[i]});
  };
  add("mu", p.mu, 3, 3);
  add("velocity", p.velocity, 9, 9);
  add("log_scale", p.log_scale, 3, 3);
  add("q0", p.q0, 4, 4);
  add("q1", p.q1, 4, 4);
  add("sh", p.sh, 48, 3 * sh_coeffs(sh_degree));
  add("opacity_logit", p.opacity_logit, 1, 1);
  if (rep == Representation::kStgs) {
    add("mu_tau", p.mu_tau, 1, 1);
    add("temporal_log_scale", p.temporal_log_scale, 1, 1);
  }
  return out;
}

std::vector<double*> gradients(G& g, Representation rep, int sh_degree) {
  std::vector<double*> out;
  auto add = [&](std::vector<double>& v, int width, int used) {
    for (std::size_t i = 0; i < v.size(); ++i)
      if (int(i % width) < used) out.push_back(&v[i]);
  };
  add(g.v_mu, 3, 3);
  add(g.v_velocity, 9, 9);
  add(g.v_log_scale, 3, 3);
  add(g.v_q0, 4, 4);
  add(g.v_q1, 4, 4);
  add(g.v_sh, 48, 3 * sh_coeffs(sh_degree));
  add(g.v_opacity_logit, 1, 1);
  if (rep == Representation::kStgs) {
    add(g.v_mu_tau, 1, 1);
    add(g.v_temporal_log_scale, 1, 1);
  }
  return out;
}

void expect_gradients_match(P& p, Representation rep, int sh_degree, G& analytic,
                            const std::function<double()>& loss, double eps, double tol) {
  const auto params = parameters(p, rep, sh_degree);
  const auto grads = gradients(analytic, rep, sh_degree);
  ASSERT_EQ(params.size(), grads.size());
  int nonzero = 0;
  for (std::size_t k = 0; k < params.size(); ++k) {
    const double fd = test::central_difference(*params[k].second, eps, loss);
    EXPECT_NEAR(*grads[k], fd, tol * (1 + std::abs(fd))) << params[k].first;
    nonzero += std::abs(fd) > 1e-6;
  }
  EXPECT_GT(nonzero, int(params.size()) / 4) << "the loss should depend on many parameters";
}

struct Case {
  Representation rep;
  TrajectoryKind trajectory;
  double t;
  SliceOptions options;
  const char* name;
};

// Loss = Σ W ⊙ (every field of the sliced batch), W fixed random weights per row.
TEST(Slice, BackwardMatchesFiniteDifferences) {
  const Camera cam = small_camera();
  std::vector<Case> cases;
  SliceOptions plain, flow, left, right;
  plain.min_opacity = flow.min_opacity = left.min_opacity = right.min_opacity = 0;
  flow.flow_features = true;
  left.group = Group::kLeft, left.compensate = true, left.flow_features = true;
  right.group = Group::kRight, right.compensate = true, right.flow_features = true;
  cases.push_back({Representation::kRetime, TrajectoryKind::kCatmullRom, 4.7, plain, "in-between"});
  cases.push_back({Representation::kRetime, TrajectoryKind::kCatmullRom, 4.0, plain, "at edge"});
  cases.push_back({Representation::kRetime, TrajectoryKind::kCatmullRom, 4.0, flow, "all + flow"});
  cases.push_back({Representation::kRetime, TrajectoryKind::kCatmullRom, 4.0, left, "left group"});
  cases.push_back(
      {Representation::kRetime, TrajectoryKind::kCatmullRom, 4.0, right, "right group"});
  cases.push_back({Representation::kRetime, TrajectoryKind::kLinear, 5.3, flow, "linear"});
  cases.push_back({Representation::kStgs, TrajectoryKind::kCatmullRom, 3.4, plain, "stgs"});
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    ModelConfig config;
    config.representation = c.rep;
    config.trajectory = c.trajectory;
    config.sh_degree = 3;
    P p = random_primitives(c.rep, 17);
    const auto fwd = slice(p, config, kGrid, c.t, cam, c.options);
    ASSERT_GT(fwd.gaussians.size(), 0u);
    std::mt19937 rng(5);
    std::normal_distribution<double> normal;
    GaussianGradsT<double> w(fwd.gaussians.size(), fwd.gaussians.channels);
    for (auto* v : {&w.v_means, &w.v_log_scales, &w.v_quats, &w.v_opacities, &w.v_features})
      for (double& x : *v) x = normal(rng);
    auto loss = [&] {
      const auto e = slice(p, config, kGrid, c.t, cam, c.options);
      double sum = 0;
      auto dot = [&](const std::vector<double>& a, const UninitVector<double>& b) {
        for (std::size_t i = 0; i < a.size(); ++i) sum += a[i] * b[i];
      };
      dot(e.gaussians.means, w.v_means), dot(e.gaussians.log_scales, w.v_log_scales);
      dot(e.gaussians.quats, w.v_quats), dot(e.gaussians.opacities, w.v_opacities);
      dot(e.gaussians.features, w.v_features);
      return sum;
    };
    G grads(p.size());
    slice_backward(p, config, kGrid, c.t, cam, c.options, fwd, w, grads);
    expect_gradients_match(p, c.rep, config.sh_degree, grads, loss, 1e-6, 1e-6);
  }
}

// A step's renders sharing one shading (shade, then slice and slice_backward given it, then
// shade_backward) give the same batches, bit for bit, and the same gradient as each render
// evaluating and differentiating its own SH colours: the triple render at a training time, and
// STGS's single render.
TEST(Slice, SharedShadingEqualsPerRenderShading) {
  const Camera cam = small_camera();
  SliceOptions all, left, right;
  all.min_opacity = left.min_opacity = right.min_opacity = 0;
  left.group = Group::kLeft, left.compensate = true, left.flow_features = true;
  right.group = Group::kRight, right.compensate = true, right.flow_features = true;
  struct SharedCase {
    Representation rep;
    double t;
    std::vector<SliceOptions> passes;
  };
  for (const SharedCase& c : {SharedCase{Representation::kRetime, 4.0, {all, left, right}},
                              SharedCase{Representation::kStgs, 3.4, {all}}}) {
    SCOPED_TRACE(int(c.rep));
    ModelConfig config;
    config.representation = c.rep;
    const P p = random_primitives(c.rep, 23, 12);
    std::vector<std::int32_t> rows(p.size());
    for (std::size_t i = 0; i < rows.size(); ++i) rows[i] = std::int32_t(i);
    ShadedT<double> shaded;
    shade(p, config, kGrid, c.t, cam, rows, shaded);
    G own(p.size()), shared(p.size());
    std::mt19937 rng(9);
    std::normal_distribution<double> normal;
    for (SliceOptions options : c.passes) {
      options.rows = &rows;
      const auto plain = slice(p, config, kGrid, c.t, cam, options);
      TimeSliceT<double> with;
      slice(p, config, kGrid, c.t, cam, options, with, &shaded);
      ASSERT_GT(plain.gaussians.size(), 0u);
      EXPECT_EQ(with.gaussians.features, plain.gaussians.features);
      EXPECT_EQ(with.gaussians.means, plain.gaussians.means);
      EXPECT_EQ(with.primitive_from_gaussian, plain.primitive_from_gaussian);
      GaussianGradsT<double> w(plain.gaussians.size(), plain.gaussians.channels);
      for (auto* v : {&w.v_means, &w.v_log_scales, &w.v_quats, &w.v_opacities, &w.v_features})
        for (double& x : *v) x = normal(rng);
      slice_backward(p, config, kGrid, c.t, cam, options, plain, w, own);
      slice_backward(p, config, kGrid, c.t, cam, options, with, w, shared, &shaded);
    }
    shade_backward(p, config, kGrid, c.t, cam, rows, shaded, shared);
    const auto expected = gradients(own, c.rep, config.sh_degree);
    const auto actual = gradients(shared, c.rep, config.sh_degree);
    ASSERT_EQ(expected.size(), actual.size());
    int nonzero = 0;
    for (std::size_t k = 0; k < expected.size(); ++k) {
      EXPECT_NEAR(*actual[k], *expected[k], 1e-12 * (1 + std::abs(*expected[k]))) << k;
      nonzero += *expected[k] != 0;
    }
    EXPECT_GT(nonzero, int(expected.size()) / 2);
  }
}

TEST(Slice, GroupsCompensationAndFlowFeatures) {
  const Camera cam = small_camera();
  ModelConfig config;
  P p = random_primitives(Representation::kRetime, 3);
  SliceOptions all, left, right;
  left.group = Group::kLeft, left.compensate = true, left.flow_features = true;
  right.group = Group::kRight, right.compensate = true, right.flow_features = true;
  const auto at4 = slice(p, config, kGrid, 4.0, cam, all);
  const auto l = slice(p, config, kGrid, 4.0, cam, left);
  const auto r = slice(p, config, kGrid, 4.0, cam, right);
  // Group L at t = 4: intervals [2, 4] (μ_τ = 3) and the stretched one; R: [4, 6] and it.
  std::vector<int> expect_l, expect_r;
  for (int i = 0; i < int(p.size()); ++i) {
    if (p.mu_tau[i] == 3.0 || i == 4) expect_l.push_back(i);
    if (p.mu_tau[i] == 5.0) expect_r.push_back(i);
  }
  EXPECT_EQ(std::vector<int>(l.primitive_from_gaussian.begin(), l.primitive_from_gaussian.end()),
            expect_l);
  EXPECT_EQ(std::vector<int>(r.primitive_from_gaussian.begin(), r.primitive_from_gaussian.end()),
            expect_r);
  // All-primitives render at a training time: each non-stretched neighbour at half opacity
  // (σ_τ = ½ at its own edge); compensated group renders use the full σ.
  for (std::size_t row = 0; row < at4.gaussians.size(); ++row) {
    const int i = at4.primitive_from_gaussian[row];
    const double sigma = sigmoid(double(p.opacity_logit[i]));
    if (p.mu_tau[i] == 3.0 || (p.mu_tau[i] == 5.0 && i != 4)) {
      EXPECT_NEAR(at4.gaussians.opacities[row], 0.5 * sigma, 1e-6) << i;
    }
  }
  for (std::size_t row = 0; row < l.gaussians.size(); ++row) {
    const int i = l.primitive_from_gaussian[row];
    EXPECT_NEAR(l.gaussians.opacities[row], sigmoid(double(p.opacity_logit[i])), 1e-6);
    EXPECT_EQ(l.gaussians.channels, 7);
  }
  // Flow features of group R at t = 4 (at p1): forward = π(p2) - π(p1).
  const int i = expect_r[0];
  const std::size_t row = 0;
  auto project = [&](double s) {  // control point p1 (s = -1) or p2 (s = +1): μ ± ½Δt v2
    Eigen::Vector3d x;
    for (int a = 0; a < 3; ++a) x[a] = p.mu[3 * i + a] + s * 1.0 * p.velocity[9 * i + 3 + a];
    return cam.project(x);
  };
  const Eigen::Vector2d fwd = project(1) - project(-1);
  EXPECT_NEAR(r.gaussians.features[7 * row + 3], fwd.x(), 1e-9);
  EXPECT_NEAR(r.gaussians.features[7 * row + 4], fwd.y(), 1e-9);
  // The primitive is rendered at p1 = x(t_i).
  const Eigen::Vector2d rendered = cam.project(
      Eigen::Vector3d(r.gaussians.means[0], r.gaussians.means[1], r.gaussians.means[2]));
  EXPECT_LT((rendered - project(-1)).norm(), 1e-9);
  // Groups exist only at training times, and not beyond the clip ends.
  EXPECT_THROW(slice(p, config, kGrid, 4.5, cam, left), Error);
  EXPECT_THROW(slice(p, config, kGrid, 0.0, cam, left), Error);
  EXPECT_THROW(slice(p, config, kGrid, 8.0, cam, right), Error);
}

// The whole chain: slice -> reference rasteriser (double) -> Σ W ⊙ image, with RGB + flow.
// Σ w ⊙ the reference render of a batch: a loss whose gradient is w, with fixed random weights
// over every channel, rendered smoothly (no alpha cut-off or early stop: finite differences only).
struct WeightedRender {
  Camera camera;
  std::vector<double> w, background;
  render::RenderOptions options;
  WeightedRender(const Camera& cam, int channels, unsigned seed)
      : camera(cam), w(std::size_t(cam.width) * cam.height * channels), background(channels, 0.2) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> normal;
    for (double& x : w) x = normal(rng);
    options.min_alpha = 0;
    options.min_transmittance = 0;
    options.alpha_clamp = 1;
  }
  double loss(const TimeSliceT<double>& e) const {
    const auto img = render::reference_forward(e.gaussians, camera, background.data(), options);
    double sum = 0;
    for (std::size_t k = 0; k < w.size(); ++k) sum += w[k] * img.image[k];
    return sum;
  }
  GaussianGradsT<double> backward(const TimeSliceT<double>& e) const {
    return render::reference_backward(e.gaussians, camera, background.data(), options, w.data(),
                                      nullptr, nullptr);
  }
};

TEST(Slice, ChainThroughRasteriserMatchesFiniteDifferences) {
  const Camera cam = small_camera(20, 16);
  for (const auto& [rep, group, t] : {std::tuple{Representation::kRetime, Group::kRight, 4.0},
                                      std::tuple{Representation::kRetime, Group::kAll, 4.6},
                                      std::tuple{Representation::kStgs, Group::kAll, 4.6}}) {
    ModelConfig config;
    config.representation = rep;
    config.sh_degree = 2;
    P p = random_primitives(rep, 29, 8);
    SliceOptions options;
    options.min_opacity = 0;
    options.group = group;
    options.compensate = group != Group::kAll;
    options.flow_features = rep == Representation::kRetime;
    const WeightedRender render(cam, options.flow_features ? 7 : 3, 9);
    auto loss = [&] { return render.loss(slice(p, config, kGrid, t, cam, options)); };
    const auto e = slice(p, config, kGrid, t, cam, options);
    const auto v_gaussians = render.backward(e);
    G grads(p.size());
    slice_backward(p, config, kGrid, t, cam, options, e, v_gaussians, grads);
    expect_gradients_match(p, rep, config.sh_degree, grads, loss, 1e-6, 2e-5);
  }
}

// d loss / d t (slice_time_vjp, what a camera's clock is refined by) against central differences
// in t of the reference render of the slice, for both representations and both trajectories, at
// times inside and beyond primitives' own intervals and across window edges.
TEST(Slice, TimeGradientMatchesFiniteDifferences) {
  const Camera cam = small_camera(20, 16);
  struct TimeCase {
    Representation rep;
    TrajectoryKind trajectory;
    double t;
    bool flow_features;
  };
  int cases = 0;
  for (const TimeCase& c :
       {TimeCase{Representation::kRetime, TrajectoryKind::kCatmullRom, 4.6, true},
        TimeCase{Representation::kRetime, TrajectoryKind::kCatmullRom, 2.3, false},
        TimeCase{Representation::kRetime, TrajectoryKind::kLinear, 5.7, false},
        TimeCase{Representation::kStgs, TrajectoryKind::kCatmullRom, 4.6, false}}) {
    ModelConfig config;
    config.representation = c.rep;
    config.trajectory = c.trajectory;
    config.sh_degree = 2;
    const P p = random_primitives(c.rep, 31, 8);
    SliceOptions options;
    options.min_opacity = 0;
    options.flow_features = c.flow_features;
    const int channels = options.flow_features ? 7 : 3;
    const WeightedRender render(cam, channels, 13);
    auto loss = [&](double t) { return render.loss(slice(p, config, kGrid, t, cam, options)); };
    const auto e = slice(p, config, kGrid, c.t, cam, options);
    const auto v_gaussians = render.backward(e);
    const double analytic = slice_time_vjp(p, config, kGrid, c.t, cam, options, e, v_gaussians);
    constexpr double kStep = 1e-6;
    const double numeric = (loss(c.t + kStep) - loss(c.t - kStep)) / (2 * kStep);
    EXPECT_GT(std::abs(numeric), 1e-2) << "t = " << c.t << ": the loss should depend on the time";
    EXPECT_NEAR(analytic, numeric, 1e-5 * (1 + std::abs(numeric))) << "t = " << c.t;
    // The float rows sum to the double ones.
    const PrimitivesT<float> pf = float_primitives(p);
    const auto ef = slice(pf, config, kGrid, c.t, cam, options);
    // The float batch may leave out rows whose σ_τ underflows: each row takes the gradient of its
    // primitive's row in the double batch.
    GaussianGradsT<float> vf(ef.gaussians.size(), v_gaussians.channels);
    for (std::size_t row = 0; row < ef.gaussians.size(); ++row) {
      const auto& from = e.primitive_from_gaussian;
      const std::size_t k = std::size_t(
          std::find(from.begin(), from.end(), ef.primitive_from_gaussian[row]) - from.begin());
      ASSERT_LT(k, from.size());
      const auto copy = [&](const auto& source, auto& target, int width) {
        for (int a = 0; a < width; ++a) target[width * row + a] = float(source[width * k + a]);
      };
      copy(v_gaussians.v_means, vf.v_means, 3);
      copy(v_gaussians.v_log_scales, vf.v_log_scales, 3);
      copy(v_gaussians.v_quats, vf.v_quats, 4);
      copy(v_gaussians.v_opacities, vf.v_opacities, 1);
      copy(v_gaussians.v_features, vf.v_features, channels);
    }
    EXPECT_NEAR(slice_time_vjp(pf, config, kGrid, c.t, cam, options, ef, vf), analytic,
                1e-4 * (1 + std::abs(analytic)));
    ++cases;
  }
  EXPECT_EQ(cases, 4);
}

// The selection runs in chunks on all threads and the in-place overload reuses a batch: either
// way the batch is the value overload's on one thread, byte for byte, for every group, whether the
// reused batch held a bigger or a smaller one before.
TEST(Slice, ThreadCountsAndReusedBatchesGiveTheSameBatch) {
  const PrimitivesT<float> p =
      float_primitives(random_primitives(Representation::kRetime, 11, 20000));
  ModelConfig config;
  config.sh_degree = 3;
  std::vector<std::int32_t> rows;
  for (std::int32_t i = 0; i < std::int32_t(p.size()); i += 1 + i % 3) rows.push_back(i);
  const Camera camera = small_camera(64, 48);
  const auto same = [](const TimeSliceT<float>& a, const TimeSliceT<float>& b) {
    return a.gaussians.channels == b.gaussians.channels && a.gaussians.means == b.gaussians.means &&
           a.gaussians.log_scales == b.gaussians.log_scales &&
           a.gaussians.quats == b.gaussians.quats &&
           a.gaussians.opacities == b.gaussians.opacities &&
           a.gaussians.features == b.gaussians.features &&
           a.primitive_from_gaussian == b.primitive_from_gaussian && a.temporal == b.temporal;
  };
  const int threads_before = max_threads();
  TimeSliceT<float> reused;
  for (const Group group : {Group::kAll, Group::kLeft, Group::kRight, Group::kAll}) {
    SliceOptions options;
    options.group = group;
    options.compensate = group != Group::kAll;
    options.flow_features = group != Group::kAll;
    options.rows = group == Group::kRight ? nullptr : &rows;
    set_threads(1);
    const TimeSliceT<float> serial = slice(p, config, kGrid, 4.0, camera, options);
    EXPECT_GT(serial.primitive_from_gaussian.size(), 1000u);
    for (const int threads : {2, 3}) {
      set_threads(threads);
      EXPECT_TRUE(same(slice(p, config, kGrid, 4.0, camera, options), serial)) << threads;
      slice(p, config, kGrid, 4.0, camera, options, reused);
      EXPECT_TRUE(same(reused, serial)) << threads;
    }
  }
  set_threads(threads_before);
}

// A bad row list is reported at its first bad entry whatever the thread count: with more chunks
// than candidates, one thread runs several chunks, and a later chunk's entry must not win.
TEST(Slice, BadRowListNamesItsFirstBadEntry) {
  const PrimitivesT<float> p = float_primitives(random_primitives(Representation::kRetime, 7, 40));
  const int threads_before = max_threads();
  for (const int threads : {1, 2, 16}) {
    set_threads(threads);
    for (const auto& [rows, message] :
         std::vector<std::pair<std::vector<std::int32_t>, std::string>>{
             {{-1, 2}, "row list entry 0 (-1)"},
             {{0, 5, 5, 9}, "row list entry 2 (5)"},
             {{1, 2, 40}, "row list entry 2 (40)"}}) {
      SliceOptions options;
      options.rows = &rows;
      const std::string error =
          test::message_of([&] { slice(p, ModelConfig{}, kGrid, 4.0, small_camera(), options); });
      EXPECT_NE(error.find(message), std::string::npos) << threads << ": " << error;
    }
  }
  set_threads(threads_before);
}

}  // namespace
}  // namespace retimegs::model
