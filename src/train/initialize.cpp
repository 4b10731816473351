#include "retimegs/train/initialize.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>

#include <fmt/format.h>
#include <Eigen/Eigenvalues>

#include "retimegs/core/pinhole.hpp"
#include "retimegs/model/sh.hpp"
#include "retimegs/train/neighbors.hpp"

namespace retimegs::train {

namespace {

constexpr int kDepthSplat = 1;                // z-buffer footprint of a point: (2r + 1)^2 pixels
constexpr double kOcclusionTolerance = 0.03;  // relative depth slack of the visibility test

// Bilinear flow sample at continuous pixel (u, v) (centres at +0.5); false when any of the four
// taps is outside or unknown.
bool sample_flow(const Flow& f, double u, double v, Eigen::Vector2d& out) {
  const double x = u - 0.5, y = v - 0.5;
  const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= f.width || y0 + 1 >= f.height) return false;
  const double fx = x - x0, fy = y - y0;
  out.setZero();
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const std::size_t i = std::size_t(y0 + dy) * f.width + (x0 + dx);
      if (!f.valid[i]) return false;
      const double w = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy);
      out += w * Eigen::Vector2d(f.uv[2 * i], f.uv[2 * i + 1]);
    }
  return true;
}

}  // namespace

namespace {

// A flow observation of one point in one camera: where the point's pixel moves to.
struct Observation {
  const Camera* camera;
  Eigen::Vector2d target;  // projection + flow
};

// The 3-D displacement d that best explains the observations: least squares of
// π_c(x + d) - target_c over the cameras (Gauss-Newton). With one camera, or views too close to
// parallel to fix the depth, it falls back to the average of the per-camera lifts at x's depth —
// which alone would underestimate motion along each camera's viewing direction.
Eigen::Vector3d solve_displacement(const Eigen::Vector3d& x, const std::vector<Observation>& obs) {
  constexpr int kIterations = 4;
  constexpr double kMinConditioning = 1e-3;  // smallest / largest eigenvalue of JᵀJ
  Eigen::Vector3d lifted = Eigen::Vector3d::Zero();
  for (const Observation& o : obs)
    lifted += o.camera->unproject(o.target, o.camera->world_to_cam(x).z()) - x;
  lifted /= double(obs.size());
  if (obs.size() < 2) return lifted;
  Eigen::Vector3d d = lifted;
  for (int it = 0; it < kIterations; ++it) {
    Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    for (const Observation& o : obs) {
      const Eigen::Vector3d p = o.camera->world_to_cam(x + d);
      if (p.z() <= 1e-6) return lifted;
      // d π / d x_world = d π / d p · R
      const Eigen::Matrix<double, 2, 3> j =
          PinholeT<double>(*o.camera).jacobian(p.x(), p.y(), p.z()).matrix() * o.camera->rotation();
      const Eigen::Vector2d r = o.camera->project_cam(p) - o.target;
      a += j.transpose() * j;
      b -= j.transpose() * r;
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(a);
    if (eig.eigenvalues()(0) < kMinConditioning * eig.eigenvalues()(2)) return lifted;
    d += a.ldlt().solve(b);
  }
  return d.allFinite() ? d : lifted;
}

}  // namespace

std::vector<PointMotion> estimate_point_motion(const TrainingSet& set, int slot) {
  const io::PointCloud& cloud = *set.points[slot];
  const std::size_t n = cloud.size();
  std::vector<std::vector<Observation>> forward(n), backward(n);
  for (std::size_t c = 0; c < set.cameras.size(); ++c) {
    const Camera& cam = set.scene.cameras[set.cameras[c]];
    const auto& fwd = set.forward[c][slot];
    const auto& bwd = set.backward[c][slot];
    if (!fwd && !bwd) continue;
    // The point cloud's own depth map in this camera (a small splat per point).
    std::vector<float> depth(std::size_t(cam.width) * cam.height,
                             std::numeric_limits<float>::infinity());
    std::vector<Eigen::Vector3d> in_camera(n);
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d x(cloud.xyz[3 * i], cloud.xyz[3 * i + 1], cloud.xyz[3 * i + 2]);
      in_camera[i] = cam.world_to_cam(x);
      if (in_camera[i].z() <= 1e-6) continue;
      const Eigen::Vector2d uv = cam.project_cam(in_camera[i]);
      const int px = int(std::floor(uv.x())), py = int(std::floor(uv.y()));
      for (int dy = -kDepthSplat; dy <= kDepthSplat; ++dy)
        for (int dx = -kDepthSplat; dx <= kDepthSplat; ++dx) {
          const int sx = px + dx, sy = py + dy;
          if (sx < 0 || sy < 0 || sx >= cam.width || sy >= cam.height) continue;
          float& d = depth[std::size_t(sy) * cam.width + sx];
          d = std::min(d, float(in_camera[i].z()));
        }
    }
    for (std::size_t i = 0; i < n; ++i) {
      const double z = in_camera[i].z();
      if (z <= 1e-6) continue;
      const Eigen::Vector2d uv = cam.project_cam(in_camera[i]);
      if (!cam.in_image(uv)) continue;
      const float nearest = depth[std::size_t(uv.y()) * cam.width + std::size_t(uv.x())];
      if (z > nearest * (1 + kOcclusionTolerance)) continue;  // occluded
      Eigen::Vector2d f;
      if (fwd && sample_flow(*fwd, uv.x(), uv.y(), f)) forward[i].push_back({&cam, uv + f});
      if (bwd && sample_flow(*bwd, uv.x(), uv.y(), f)) backward[i].push_back({&cam, uv + f});
    }
  }
  std::vector<PointMotion> motion(n);
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d x(cloud.xyz[3 * i], cloud.xyz[3 * i + 1], cloud.xyz[3 * i + 2]);
    PointMotion& m = motion[i];
    m.forward_views = int(forward[i].size()), m.backward_views = int(backward[i].size());
    if (m.forward_views) m.forward = solve_displacement(x, forward[i]);
    if (m.backward_views) m.backward = solve_displacement(x, backward[i]);
  }
  return motion;
}

model::Primitives initialize(const TrainingSet& set, const InitOptions& options,
                             std::string& note) {
  const int nf = int(set.frames.size());
  const double step = set.grid.step;
  const bool stgs = options.representation == model::Representation::kStgs;
  // Seeds: position, velocity, colour, interval (or STGS frame time).
  std::vector<float> xyz, velocity, rgb, time;
  bool any_points = false;
  for (const auto& p : set.points) any_points |= p.has_value() && p->size() > 0;

  std::mt19937_64 rng(options.seed);
  if (!any_points) {
    // Random fallback: points uniform in the box prepare's random points are drawn from.
    const io::Box box = io::cameras_look_box(set.scene, set.cameras);
    const Eigen::Vector3d& centre = box.centre;
    const double half = box.half;
    std::uniform_real_distribution<double> u(-1, 1), colour(0, 1);
    for (std::size_t k = 0; k < io::kRandomPointsTotal; ++k) {
      for (int a = 0; a < 3; ++a) xyz.push_back(float(centre[a] + half * u(rng)));
      for (int a = 0; a < 3; ++a) rgb.push_back(float(colour(rng)));
      velocity.insert(velocity.end(), {0, 0, 0});
      const int slot = int(k % std::size_t(stgs ? nf : nf - 1));
      time.push_back(float(stgs ? set.grid.at(slot) : set.grid.at(slot) + step / 2));
    }
    note = fmt::format(
        "initialisation: the scene has no points; {} random points in a box of side "
        "{:.3g} around ({:.3g}, {:.3g}, {:.3g})",
        io::kRandomPointsTotal, 2 * half, centre.x(), centre.y(), centre.z());
  } else {
    std::size_t with_motion = 0, total = 0;
    for (int i = 0; i < nf; ++i) {
      if (!set.points[i]) continue;
      const io::PointCloud& cloud = *set.points[i];
      const std::vector<PointMotion> motion = options.use_flow && !stgs
                                                  ? estimate_point_motion(set, i)
                                                  : std::vector<PointMotion>(cloud.size());
      for (std::size_t k = 0; k < cloud.size(); ++k) {
        const PointMotion& m = motion[k];
        // v = mean of the forward and the negated backward displacement, per frame.
        Eigen::Vector3d v = Eigen::Vector3d::Zero();
        if (m.forward_views && m.backward_views)
          v = 0.5 * (m.forward - m.backward) / step;
        else if (m.forward_views)
          v = m.forward / step;
        else if (m.backward_views)
          v = -m.backward / step;
        with_motion += (m.forward_views + m.backward_views) > 0;
        ++total;
        const Eigen::Vector3d x(cloud.xyz[3 * k], cloud.xyz[3 * k + 1], cloud.xyz[3 * k + 2]);
        const Eigen::Vector3f colour =
            cloud.rgb.empty()
                ? Eigen::Vector3f(0.5f, 0.5f, 0.5f)
                : Eigen::Vector3f(cloud.rgb[3 * k], cloud.rgb[3 * k + 1], cloud.rgb[3 * k + 2]);
        auto add = [&](const Eigen::Vector3d& p, double t) {
          for (int a = 0; a < 3; ++a) xyz.push_back(float(p[a]));
          for (int a = 0; a < 3; ++a) velocity.push_back(float(v[a]));
          for (int a = 0; a < 3; ++a) rgb.push_back(colour[a]);
          time.push_back(float(t));
        };
        if (stgs) {
          add(x, set.grid.at(i));
          continue;
        }
        // Frame t_i seeds interval [t_i, t_{i+1}] (moved forward by ½Δt v) and [t_{i-1}, t_i]
        // (moved back by ½Δt v).
        if (i + 1 < nf) add(x + 0.5 * step * v, set.grid.at(i) + step / 2);
        if (i > 0) add(x - 0.5 * step * v, set.grid.at(i) - step / 2);
      }
    }
    note = fmt::format("initialisation: {} points from {} frames, {} with flow-based motion{}",
                       total, nf, with_motion,
                       stgs               ? " (STGS baseline: no motion)"
                       : options.use_flow ? ""
                                          : " (no-flow-init: motion off)");
  }

  // Deterministic subsample to the budget.
  std::size_t count = time.size();
  std::vector<std::size_t> keep(count);
  std::iota(keep.begin(), keep.end(), 0);
  if (count > options.max_primitives) {
    std::shuffle(keep.begin(), keep.end(), rng);
    keep.resize(options.max_primitives);
    std::sort(keep.begin(), keep.end());
    count = keep.size();
  }
  std::vector<float> positions(3 * count);
  for (std::size_t j = 0; j < count; ++j)
    for (int a = 0; a < 3; ++a) positions[3 * j + a] = xyz[3 * keep[j] + a];
  const std::vector<float> scale =
      mean_neighbor_distance(positions, float(0.01 * set.scene_extent));

  model::Primitives p;
  p.resize(count);
  const float logit = float(std::log(options.initial_opacity / (1 - options.initial_opacity)));
  for (std::size_t j = 0; j < count; ++j) {
    const std::size_t k = keep[j];
    for (int a = 0; a < 3; ++a) {
      p.mu[3 * j + a] = positions[3 * j + a];
      p.log_scale[3 * j + a] = std::log(std::max(scale[j], 1e-7f));
      p.sh[model::Primitives::kShWidth * j + a] = float((rgb[3 * k + a] - 0.5) / model::kShC0);
      if (!stgs)  // v1 = v2 = v3 (STGS polynomial coefficients start at zero)
        for (int r = 0; r < 3; ++r) p.velocity[9 * j + 3 * r + a] = velocity[3 * k + a];
    }
    p.q0[4 * j] = 1;
    p.opacity_logit[j] = logit;
    p.mu_tau[j] = time[k];
    p.tau_l[j] = p.tau_r[j] = float(step / 2);
    p.temporal_log_scale[j] = float(std::log(step));  // STGS: σ_τ is 1/e one interval off μ_τ
  }
  return p;
}

}  // namespace retimegs::train
