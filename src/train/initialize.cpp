#include "retimegs/train/initialize.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <numeric>
#include <random>
#include <tuple>
#include <utility>

#include <fmt/format.h>
#include <Eigen/Eigenvalues>

#include "retimegs/core/pinhole.hpp"
#include "retimegs/model/sh.hpp"
#include "retimegs/train/neighbors.hpp"
#include "retimegs/train/stretch.hpp"

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

namespace {

// Initial primitives before the budget: position, velocity (per frame), colour, window.
struct Seeds {
  std::vector<float> xyz, velocity, rgb, mu_tau, half_window;
  // The flow-aware path's seeds: the training interval (slot of its first frame), the point
  // (frame slot, index in that frame's cloud) each comes from, and whether the flows of two or
  // more views measured its motion (one view is blind to motion along its viewing direction, and
  // a point no flow sees has velocity zero for want of evidence, not for standing still).
  std::vector<int> interval, frame;
  std::vector<std::uint32_t> point;
  std::vector<char> measured;

  std::size_t size() const { return mu_tau.size(); }
  void add(const Eigen::Vector3d& x, const Eigen::Vector3d& v, const Eigen::Vector3f& colour,
           double t, double half) {
    for (int a = 0; a < 3; ++a) {
      xyz.push_back(float(x[a]));
      velocity.push_back(float(v[a]));
      rgb.push_back(colour[a]);
    }
    mu_tau.push_back(float(t));
    half_window.push_back(float(half));
  }
};

// Union-find over seeds whose sets hold at most one point per frame: two different points seen at
// the same frame are two features, however close, and must not become one primitive.
class Chains {
 public:
  explicit Chains(const Seeds& seeds) : parent_(seeds.size()), points_(seeds.size()) {
    std::iota(parent_.begin(), parent_.end(), 0);
    for (std::size_t i = 0; i < seeds.size(); ++i) points_[i] = {{seeds.frame[i], seeds.point[i]}};
  }
  std::size_t root(std::size_t i) {
    while (parent_[i] != i) i = parent_[i] = parent_[parent_[i]];
    return i;
  }
  // Joins the chains of a and b unless they hold different points of one frame.
  void join(std::size_t a, std::size_t b) {
    a = root(a), b = root(b);
    if (a == b) return;
    std::vector<std::pair<int, std::uint32_t>> both;
    std::merge(points_[a].begin(), points_[a].end(), points_[b].begin(), points_[b].end(),
               std::back_inserter(both));
    both.erase(std::unique(both.begin(), both.end()), both.end());
    for (std::size_t k = 1; k < both.size(); ++k)
      if (both[k].first == both[k - 1].first) return;
    parent_[b] = a;
    points_[a] = std::move(both);
    points_[b].clear();
  }

 private:
  std::vector<std::size_t> parent_;
  std::vector<std::vector<std::pair<int, std::uint32_t>>> points_;  // per root, sorted
};

// Static content once (paper §3.3.3's stretching criterion, applied to the seeds): at every inner
// training frame t_b the seeds of the interval ending there are matched with those of the interval
// starting there, and those with these (train/stretch.hpp's match_at_frame, positions at t_b).
// Matched pairs join one chain, closest pairs first (seeds whose motion is not measured take no
// part), and each chain of two or more seeds becomes one primitive: window the union of its
// (adjacent) intervals, velocity zero, position the mean of where its points were seen, colour
// their mean. A static point thus
// starts as one primitive over all the frames it is seen at, instead of one copy per interval that
// meet (and are drawn differently) at every training frame; a moving point's seeds fail the speed
// test and stay per interval. Returns how many seeds were merged into how many primitives.
std::pair<std::size_t, std::size_t> merge_static(Seeds& seeds, const model::TimeGrid& grid,
                                                 const StretchSettings& settings) {
  struct Pair {
    float d2;
    std::size_t a, c;
  };
  std::vector<Pair> pairs;
  for (int b = 1; b + 1 < grid.count; ++b) {
    const double tb = grid.at(b);
    std::vector<std::size_t> ending, starting;
    for (std::size_t i = 0; i < seeds.size(); ++i) {
      if (seeds.interval[i] == b - 1) ending.push_back(i);
      if (seeds.interval[i] == b) starting.push_back(i);
    }
    auto side = [&](const std::vector<std::size_t>& items) {
      StretchSide out;
      for (const std::size_t i : items) {
        const float dt = float(tb - seeds.mu_tau[i]);
        double speed = 0;
        for (int a = 0; a < 3; ++a) {
          const float v = seeds.velocity[3 * i + a];
          out.xyz.push_back(seeds.xyz[3 * i + a] + dt * v);
          out.color.push_back(seeds.rgb[3 * i + a]);
          speed += double(v) * v;
        }
        out.speed.push_back(seeds.measured[i] ? std::sqrt(speed)
                                              : std::numeric_limits<double>::infinity());
      }
      return out;
    };
    // Both ways: each seed's nearest neighbour across t_b, so that no seed on either side is left
    // out of its chain for having lost a near tie on the other side.
    const StretchSide end_side = side(ending), start_side = side(starting);
    auto add_pairs = [&](const StretchSide& from, const std::vector<std::size_t>& from_ids,
                         const StretchSide& to, const std::vector<std::size_t>& to_ids) {
      const std::vector<std::int32_t> partner = match_at_frame(from, to, settings);
      for (std::size_t k = 0; k < from_ids.size(); ++k) {
        if (partner[k] < 0) continue;
        float d2 = 0;
        for (int a = 0; a < 3; ++a) {
          const float d = from.xyz[3 * k + a] - to.xyz[3 * partner[k] + a];
          d2 += d * d;
        }
        pairs.push_back({d2, from_ids[k], to_ids[partner[k]]});
      }
    };
    add_pairs(end_side, ending, start_side, starting);
    add_pairs(start_side, starting, end_side, ending);
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& x, const Pair& y) {
    return std::tie(x.d2, x.a, x.c) < std::tie(y.d2, y.a, y.c);
  });
  Chains chains(seeds);
  for (const Pair& pair : pairs) chains.join(pair.a, pair.c);

  // Chains of two or more seeds, by root; each becomes one primitive in place of its root seed.
  std::vector<std::vector<std::size_t>> members(seeds.size());
  for (std::size_t i = 0; i < seeds.size(); ++i) members[chains.root(i)].push_back(i);
  Seeds out;
  std::size_t merged = 0, primitives = 0;
  for (std::size_t r = 0; r < seeds.size(); ++r) {
    const std::vector<std::size_t>& chain = members[r];
    if (chain.empty()) continue;
    Eigen::Vector3d x = Eigen::Vector3d::Zero();
    Eigen::Vector3f colour = Eigen::Vector3f::Zero();
    double from = std::numeric_limits<double>::infinity(), to = -from;
    for (const std::size_t i : chain) {
      // The point where it was seen (a seed is moved ½Δt along its velocity).
      const float back = float(grid.at(seeds.frame[i]) - seeds.mu_tau[i]);
      for (int a = 0; a < 3; ++a) {
        x[a] += seeds.xyz[3 * i + a] + back * seeds.velocity[3 * i + a];
        colour[a] += seeds.rgb[3 * i + a];
      }
      from = std::min(from, double(seeds.mu_tau[i]) - seeds.half_window[i]);
      to = std::max(to, double(seeds.mu_tau[i]) + seeds.half_window[i]);
    }
    const double n = double(chain.size());
    const Eigen::Vector3d v =
        chain.size() == 1 ? Eigen::Vector3d(seeds.velocity[3 * r], seeds.velocity[3 * r + 1],
                                            seeds.velocity[3 * r + 2])
                          : Eigen::Vector3d::Zero();
    out.add(x / n, v, colour / float(n), 0.5 * (from + to), 0.5 * (to - from));
    if (chain.size() > 1) merged += chain.size(), ++primitives;
  }
  seeds = std::move(out);
  return {merged, primitives};
}

}  // namespace

model::Primitives initialize(const TrainingSet& set, const InitOptions& options,
                             std::string& note) {
  const int nf = int(set.frames.size());
  const double step = set.grid.step;
  const bool stgs = options.representation == model::Representation::kStgs;
  // STGS seeds a frame time with a window of one interval (its temporal scale, set below).
  const double half_interval = step / 2;
  Seeds seeds;
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
      Eigen::Vector3d x;
      Eigen::Vector3f c;
      for (int a = 0; a < 3; ++a) x[a] = centre[a] + half * u(rng);
      for (int a = 0; a < 3; ++a) c[a] = float(colour(rng));
      const int slot = int(k % std::size_t(stgs ? nf : nf - 1));
      seeds.add(x, Eigen::Vector3d::Zero(), c,
                stgs ? set.grid.at(slot) : set.grid.at(slot) + half_interval, half_interval);
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
        if (stgs) {
          seeds.add(x, v, colour, set.grid.at(i), half_interval);
          continue;
        }
        // Frame t_i seeds interval [t_i, t_{i+1}] (moved forward by ½Δt v) and [t_{i-1}, t_i]
        // (moved back by ½Δt v).
        for (const int interval : {i, i - 1}) {
          if (interval < 0 || interval + 1 >= nf) continue;
          const double sign = interval == i ? 1 : -1;
          seeds.add(x + sign * half_interval * v, v, colour, set.grid.at(i) + sign * half_interval,
                    half_interval);
          seeds.interval.push_back(interval);
          seeds.frame.push_back(i);
          seeds.point.push_back(std::uint32_t(k));
          seeds.measured.push_back(std::max(m.forward_views, m.backward_views) >= 2);
        }
      }
    }
    std::string merged;
    if (options.use_flow && options.static_once && !stgs) {
      const StretchSettings settings{options.stretch_distance * set.scene_extent,
                                     options.stretch_color,
                                     options.stretch_speed * set.scene_extent};
      const std::size_t before = seeds.size();
      const auto [seeds_merged, primitives] = merge_static(seeds, set.grid, settings);
      merged = fmt::format(
          "; static content once: {} of the {} seeds merged into {} static primitives (stretching "
          "criterion at initialisation)",
          seeds_merged, before, primitives);
    }
    note = fmt::format("initialisation: {} points from {} frames, {} with flow-based motion{}{}",
                       total, nf, with_motion,
                       stgs               ? " (STGS baseline: no motion)"
                       : options.use_flow ? ""
                                          : " (no-flow-init: motion off)",
                       merged);
  }

  // Deterministic subsample to the budget.
  std::size_t count = seeds.size();
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
    for (int a = 0; a < 3; ++a) positions[3 * j + a] = seeds.xyz[3 * keep[j] + a];
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
      p.sh[model::Primitives::kShWidth * j + a] =
          float((seeds.rgb[3 * k + a] - 0.5) / model::kShC0);
      if (!stgs)  // v1 = v2 = v3 (STGS polynomial coefficients start at zero)
        for (int r = 0; r < 3; ++r) p.velocity[9 * j + 3 * r + a] = seeds.velocity[3 * k + a];
    }
    p.q0[4 * j] = 1;
    p.opacity_logit[j] = logit;
    p.mu_tau[j] = seeds.mu_tau[k];
    p.tau_l[j] = p.tau_r[j] = seeds.half_window[k];
    p.temporal_log_scale[j] = float(std::log(step));  // STGS: σ_τ is 1/e one interval off μ_τ
  }
  return p;
}

}  // namespace retimegs::train
