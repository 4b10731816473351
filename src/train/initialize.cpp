#include "retimegs/train/initialize.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <set>
#include <tuple>
#include <utility>

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

// A flow observation of one point in one camera: where the point's pixel moves to.
struct Observation {
  const Camera* camera;
  Eigen::Vector2d target;  // projection + flow
};

// The 3-D displacement d that best explains the observations: least squares of
// π_c(x + d) - target_c over the cameras (Gauss-Newton). With one camera, or views too close to
// parallel to fix the depth, it falls back to the average of the per-camera lifts at x's depth —
// which alone would underestimate motion along each camera's viewing direction.
// `average_lifts`: the average alone (the paper's recipe, init_average_lifts).
Eigen::Vector3d solve_displacement(const Eigen::Vector3d& x, const std::vector<Observation>& obs,
                                   bool average_lifts) {
  constexpr int kIterations = 4;
  constexpr double kMinConditioning = 1e-3;  // smallest / largest eigenvalue of JᵀJ
  Eigen::Vector3d lifted = Eigen::Vector3d::Zero();
  for (const Observation& o : obs)
    lifted += o.camera->unproject(o.target, o.camera->world_to_cam(x).z()) - x;
  lifted /= double(obs.size());
  if (obs.size() < 2 || average_lifts) return lifted;
  Eigen::Vector3d d = lifted;
  for (int it = 0; it < kIterations; ++it) {
    Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    for (const Observation& o : obs) {
      const Eigen::Vector3d p = o.camera->world_to_cam(x + d);
      if (p.z() <= 1e-6) return lifted;
      // d π / d x_world = d π / d p · R
      const PinholeJacobianT<double> jp = PinholeT<double>(*o.camera).jacobian(p.x(), p.y(), p.z());
      Eigen::Matrix<double, 2, 3> j_cam;
      j_cam << jp.j00, 0.0, jp.j02, 0.0, jp.j11, jp.j12;
      const Eigen::Matrix<double, 2, 3> j = j_cam * o.camera->rotation();
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

// Where a point of a frame's cloud is seen: a training camera (slot) and its pixel there.
struct PointView {
  int camera;
  Eigen::Vector2d uv;
};

// Per point of frame slot `slot`, the training cameras that see it unoccluded (z-test against the
// cloud's own depth map, a small splat per point) and its pixel in each.
std::vector<std::vector<PointView>> point_views(const TrainingSet& set, int slot) {
  const io::PointCloud& cloud = *set.points[slot];
  const std::size_t n = cloud.size();
  std::vector<std::vector<PointView>> views(n);
  std::vector<Eigen::Vector3d> in_camera(n);
  for (std::size_t c = 0; c < set.cameras.size(); ++c) {
    const Camera& cam = set.scene.cameras[set.cameras[c]];
    std::vector<float> depth(std::size_t(cam.width) * cam.height,
                             std::numeric_limits<float>::infinity());
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
      views[i].push_back({int(c), uv});
    }
  }
  return views;
}

std::vector<PointMotion> point_motion(const TrainingSet& set, int slot,
                                      const std::vector<std::vector<PointView>>& views,
                                      bool average_lifts) {
  const io::PointCloud& cloud = *set.points[slot];
  const std::size_t n = cloud.size();
  std::vector<std::vector<Observation>> forward(n), backward(n);
  for (std::size_t i = 0; i < n; ++i)
    for (const PointView& view : views[i]) {
      const Camera& cam = set.scene.cameras[set.cameras[view.camera]];
      const auto& fwd = set.forward[view.camera][slot];
      const auto& bwd = set.backward[view.camera][slot];
      Eigen::Vector2d f;
      if (fwd && sample_flow(*fwd, view.uv.x(), view.uv.y(), f))
        forward[i].push_back({&cam, view.uv + f});
      if (bwd && sample_flow(*bwd, view.uv.x(), view.uv.y(), f))
        backward[i].push_back({&cam, view.uv + f});
    }
  std::vector<PointMotion> motion(n);
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d x(cloud.xyz[3 * i], cloud.xyz[3 * i + 1], cloud.xyz[3 * i + 2]);
    PointMotion& m = motion[i];
    m.forward_views = int(forward[i].size()), m.backward_views = int(backward[i].size());
    if (m.forward_views) m.forward = solve_displacement(x, forward[i], average_lifts);
    if (m.backward_views) m.backward = solve_displacement(x, backward[i], average_lifts);
  }
  return motion;
}

// The velocities of a trajectory's control points, per frame (docs/method.md): v1 carries p0 to
// p1, v2 p1 to p2 (the primitive's own interval), v3 p2 to p3.
struct Velocities {
  Eigen::Vector3d v1 = Eigen::Vector3d::Zero(), v2 = Eigen::Vector3d::Zero(),
                  v3 = Eigen::Vector3d::Zero();
};

// Initial primitives before the budget: position, velocities, colour and window
// [mu_tau - tau_l, mu_tau + tau_r].
struct Seeds {
  std::vector<float> xyz, velocity, rgb, mu_tau, tau_l, tau_r;  // velocity: v1, v2, v3 per row

  std::size_t size() const { return mu_tau.size(); }
  void add(const Eigen::Vector3d& x, const Velocities& v, const Eigen::Vector3f& colour, double t,
           double left, double right) {
    for (const Eigen::Vector3d* w : {&v.v1, &v.v2, &v.v3})
      for (int a = 0; a < 3; ++a) velocity.push_back(float((*w)[a]));
    for (int a = 0; a < 3; ++a) {
      xyz.push_back(float(x[a]));
      rgb.push_back(colour[a]);
    }
    mu_tau.push_back(float(t));
    tau_l.push_back(float(left));
    tau_r.push_back(float(right));
  }
};

// A point found standing still: where, its colour and the run of frame slots [first, last] over
// which it keeps its look (first < last).
struct StillPoint {
  Eigen::Vector3d x;
  Eigen::Vector3f colour;
  int first, last;
};

// The run of training frames around `slot` over which a point keeps its look in the images: frame
// j belongs while, over the views that see the point at `slot`, the median of the largest channel
// difference between the pixel at frame j and at `slot` is at most `max_color`. Each camera is
// compared with itself, so gain and white balance differences between cameras do not count, and
// the median outvotes the few views a moving object crosses. Returns {slot, slot} when even a
// neighbour frame differs or no view sees the point.
std::pair<int, int> unchanged_frames(const TrainingSet& set, int slot,
                                     const std::vector<PointView>& views, double max_color) {
  if (views.empty()) return {slot, slot};
  std::vector<float> difference(views.size());
  auto unchanged = [&](int j) {
    for (std::size_t v = 0; v < views.size(); ++v) {
      const PackedImage& here = set.images[views[v].camera][slot];
      const PackedImage& there = set.images[views[v].camera][j];
      const std::size_t pixel =
          std::size_t(views[v].uv.y()) * here.width + std::size_t(views[v].uv.x());
      int largest = 0;
      for (int ch = 0; ch < 3; ++ch)
        largest = std::max(
            largest, std::abs(int(here.data[3 * pixel + ch]) - int(there.data[3 * pixel + ch])));
      difference[v] = float(largest) / 65535.0f;
    }
    const auto middle = difference.begin() + difference.size() / 2;
    std::nth_element(difference.begin(), middle, difference.end());
    return *middle <= max_color;
  };
  int first = slot, last = slot;
  while (first > 0 && unchanged(first - 1)) --first;
  while (last + 1 < int(set.frames.size()) && unchanged(last + 1)) ++last;
  return {first, last};
}

// Static content once (paper §3.3.3's stretching criterion applied to the points, a departure from
// the paper's flow-aware initialisation; docs/method.md): a still point becomes one unmoving
// primitive over its run of frames, instead of one copy per interval that meet (and are drawn
// differently) at every training frame. Its mu_tau is the centre of the interval in the middle of
// the run, as for a stretched primitive. A point repeated verbatim with the same run (a static
// cloud written at every frame) is one primitive; points found at different frames are kept apart
// even when close: they are samples of the surface, and the initial density follows them.
void add_still_points(const std::vector<StillPoint>& still, const model::TimeGrid& grid,
                      Seeds& seeds) {
  std::set<std::tuple<float, float, float, int, int>> taken;
  for (const StillPoint& s : still) {
    if (!taken.insert({float(s.x.x()), float(s.x.y()), float(s.x.z()), s.first, s.last}).second)
      continue;
    const double mu_tau = grid.at(s.first + (s.last - s.first - 1) / 2) + 0.5 * grid.step;
    seeds.add(s.x, Velocities{}, s.colour, mu_tau, mu_tau - grid.at(s.first),
              grid.at(s.last) - mu_tau);
  }
}

}  // namespace

InitOptions init_options(const TrainConfig& config, model::Representation representation) {
  InitOptions options;
  options.use_flow = !config.ablate.no_flow_init;
  options.static_once = !config.ablate.no_static_init;
  options.representation = representation;
  options.max_primitives = config.cap;
  options.initial_opacity = config.init_opacity;
  options.seed = config.seed;
  options.stretch_color = config.stretch_color;
  options.stretch_speed = config.stretch_speed;
  options.average_lifts = config.init_average_lifts;
  options.mean_velocity = config.init_mean_velocity;
  return options;
}

std::vector<PointMotion> estimate_point_motion(const TrainingSet& set, int slot) {
  return point_motion(set, slot, point_views(set, slot), false);
}

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
      seeds.add(x, Velocities{}, c, stgs ? set.grid.at(slot) : set.grid.at(slot) + half_interval,
                half_interval, half_interval);
    }
    note = fmt::format(
        "initialisation: the scene has no points; {} random points in a box of side "
        "{:.3g} around ({:.3g}, {:.3g}, {:.3g})",
        io::kRandomPointsTotal, 2 * half, centre.x(), centre.y(), centre.z());
  } else {
    // The flows are measured for the velocities and for the static-content test alike, so that
    // the no-flow-init ablation changes the velocities only, not which points are found still.
    const bool find_still = !stgs && options.static_once;
    const bool flow = !stgs && (options.use_flow || find_still);
    const double max_speed = options.stretch_speed * set.scene_extent;
    std::vector<StillPoint> still;
    std::size_t with_motion = 0, total = 0, unmeasured = 0, fast = 0, changing = 0;
    for (int i = 0; i < nf; ++i) {
      if (!set.points[i]) continue;
      const io::PointCloud& cloud = *set.points[i];
      const std::vector<std::vector<PointView>> views =
          flow ? point_views(set, i) : std::vector<std::vector<PointView>>(cloud.size());
      const std::vector<PointMotion> motion =
          flow ? point_motion(set, i, views, options.average_lifts)
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
        with_motion += options.use_flow && (m.forward_views + m.backward_views) > 0;
        ++total;
        const Eigen::Vector3d x(cloud.xyz[3 * k], cloud.xyz[3 * k + 1], cloud.xyz[3 * k + 2]);
        const Eigen::Vector3f colour =
            cloud.rgb.empty()
                ? Eigen::Vector3f(0.5f, 0.5f, 0.5f)
                : Eigen::Vector3f(cloud.rgb[3 * k], cloud.rgb[3 * k + 1], cloud.rgb[3 * k + 2]);
        if (stgs) {  // STGS polynomial coefficients start at zero
          seeds.add(x, Velocities{}, colour, set.grid.at(i), half_interval, half_interval);
          continue;
        }
        // Standing still: the flow of at least one view measures its motion (a point no flow sees
        // has velocity zero for want of evidence), below the stretching speed, and its look holds
        // over a neighbour frame in every view that sees it. One view suffices: its flow is blind
        // to motion along its viewing direction, but such a motion changes what the view records
        // at the point's pixel (another part of the surface, or what lies behind), which the look
        // test catches. Background seen by a single camera, left out, would start as one copy per
        // interval; the copies meet at every training frame and make the static world pulse.
        if (find_still) {
          if (m.forward_views + m.backward_views == 0) {
            ++unmeasured;
          } else if (v.norm() > max_speed) {
            ++fast;
          } else {
            const auto [first, last] = unchanged_frames(set, i, views[k], options.stretch_color);
            if (first < last) {
              still.push_back({x, colour, first, last});
              continue;
            }
            ++changing;
          }
        }
        // Frame t_i seeds interval [t_i, t_{i+1}] and [t_{i-1}, t_i]. Each control point is where
        // the flows put the point: p0 at x + backward displacement (t_{i-1}), x itself at t_i, and
        // x + forward displacement (t_{i+1}); a point no flow measures in one direction moves at
        // v both ways, and the control point beyond the measured ones continues the last chord
        // (the fallback at the clip ends). The paper's initialisation sets v1 = v2 = v3 = v, the
        // mean of both displacements: on a curved or accelerating path that straight line misses
        // the point's position at the interval's far end by the path's bend (the fast synthetic
        // ball, turning 1 rad per interval, lands 0.7 m off), so the two seeds of an interval draw
        // two objects.
        // The no-flow-init ablation: the seeds start at the point, with velocities 0.
        Eigen::Vector3d into = Eigen::Vector3d::Zero(), onward = Eigen::Vector3d::Zero();
        if (options.use_flow && options.mean_velocity) {
          into = onward = v;
        } else if (options.use_flow) {
          into = m.backward_views ? Eigen::Vector3d(-m.backward / step) : v;
          onward = m.forward_views ? Eigen::Vector3d(m.forward / step) : v;
        }
        if (i + 1 < nf)
          seeds.add(x + half_interval * onward, {into, onward, onward}, colour,
                    set.grid.at(i) + half_interval, half_interval, half_interval);
        if (i > 0)
          seeds.add(x - half_interval * into, {into, into, onward}, colour,
                    set.grid.at(i) - half_interval, half_interval, half_interval);
      }
    }
    std::string merged;
    if (find_still) {
      const std::size_t before = seeds.size();
      add_still_points(still, set.grid, seeds);
      merged = fmt::format(
          "; static content once: {} still points (stretching criterion) became {} primitives "
          "spanning their frames (not still: {} whose motion no flow measures, {} "
          "faster than stretch_speed, {} whose look changes)",
          still.size(), seeds.size() - before, unmeasured, fast, changing);
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
    }
    for (int a = 0; a < 9; ++a) p.velocity[9 * j + a] = seeds.velocity[9 * k + a];
    p.q0[4 * j] = 1;
    p.opacity_logit[j] = logit;
    p.mu_tau[j] = seeds.mu_tau[k];
    p.tau_l[j] = seeds.tau_l[k];
    p.tau_r[j] = seeds.tau_r[k];
    p.temporal_log_scale[j] = float(std::log(step));  // STGS: σ_τ is 1/e one interval off μ_τ
  }
  return p;
}

}  // namespace retimegs::train
