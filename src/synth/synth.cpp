#include "retimegs/synth/synth.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/limits.hpp"
#include "retimegs/core/progress.hpp"
#include "retimegs/io/flow_io.hpp"
#include "retimegs/io/ply.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "synth_world.hpp"

namespace retimegs::synth {

using Eigen::Vector2d;
using Eigen::Vector3d;
using synth::Hit;
using synth::Posed;
using synth::World;

namespace {

// Cameras on a ring 4.5 m from the scene centre: with a 55 degree horizontal field of view the
// objects (within 1.9 m of the centre) stay in every view and fill a good part of it.
constexpr double kRingRadius = 4.5;
constexpr double kHorizontalFovDegrees = 55;
// Camera heights above the ground alternate between two values so the views differ in elevation.
constexpr double kCameraHeights[2] = {1.5, 2.1};
constexpr double kAzimuthJitter = 0.06;  // radians, per seed
constexpr double kHeightJitter = 0.1;    // metres, per seed
constexpr double kTargetJitter = 0.05;   // metres, per seed
// A flow target is visible at time `to` when the ray through its projection hits the same object
// at the same distance: double precision keeps legitimate matches within ~1e-9, while a different
// surface (an occluder, the far side of the object) is centimetres away.
constexpr double kDepthTolerance = 1e-4;  // relative
// Point clouds: a few thousand to ~20k points per frame.
constexpr double kObjectPointDensity = 1500;  // per square metre of object surface
constexpr double kGroundPointDensity = 120;   // per square metre of ground
constexpr double kGroundPointRadius = 4;      // metres around the origin: the staged area
// The far ground (out to the dome) and the sky dome, sparsely: training needs primitives there
// too, and a point cloud that stops at the stage would leave the background to chance.
constexpr long kFarGroundPoints = 3000;
constexpr long kSkyPoints = 3000;

// Upper bounds, checked before anything is allocated: a typo such as --size 100000x100000 would
// otherwise end in an allocation failure naming nothing. Images and frames as core/limits.hpp
// bounds them; cameras far beyond any capture.
constexpr int kMaxCameras = 1000;

// The preset is checked by synth::build_world.
void validate(const SynthOptions& o) {
  if (o.cameras < 1 || o.cameras > kMaxCameras)
    fail("--cameras: must lie in [1, {}], got {}", kMaxCameras, o.cameras);
  if (o.frames < 2 || o.frames > kMaxFrames)
    fail("--frames: must lie in [2, {}], got {}", kMaxFrames, o.frames);
  check_output_size(o.width, o.height, "--size");
  if (o.supersample < 1) fail("supersample: must be >= 1, got {}", o.supersample);
  check_fps(o.fps, "fps");
  for (const auto& [name, offset] : o.time_offsets)
    if (!std::isfinite(offset)) fail("--time-offsets: {}'s offset is not finite", name);
  if (o.perturb_calibration)
    io::check_calibration_perturbation(*o.perturb_calibration, "--perturb-calibration");
}

// The cameras' clocks from options.time_offsets; empty when none is given. Throws Error naming
// --time-offsets and the camera for a name that is not one of `cameras`.
std::vector<io::CameraClock> make_clocks(const SynthOptions& o,
                                         const std::vector<Camera>& cameras) {
  if (o.time_offsets.empty()) return {};
  std::vector<io::CameraClock> clocks(cameras.size());
  for (const auto& [name, offset] : o.time_offsets) {
    const auto it = std::find_if(cameras.begin(), cameras.end(),
                                 [&](const Camera& c) { return c.name == name; });
    if (it == cameras.end())
      fail("--time-offsets: no camera '{}' (cameras cam00 .. cam{:02d})", name,
           int(cameras.size()) - 1);
    clocks[std::size_t(it - cameras.begin())].time_offset = offset;
  }
  return clocks;
}

std::vector<Camera> make_cameras(const SynthOptions& o, const World& world) {
  synth::Rng rng(synth::stream_seed(o.seed, synth::kCameraStream));
  const double fx = 0.5 * o.width / std::tan(0.5 * kHorizontalFovDegrees * std::numbers::pi / 180);
  std::vector<Camera> cameras;
  for (int i = 0; i < o.cameras; ++i) {
    const double azimuth =
        2 * std::numbers::pi * i / o.cameras + rng.uniform(-kAzimuthJitter, kAzimuthJitter);
    const double height = kCameraHeights[i % 2] + rng.uniform(-kHeightJitter, kHeightJitter);
    const Vector3d eye(kRingRadius * std::cos(azimuth), -height, kRingRadius * std::sin(azimuth));
    Vector3d target = world.centre;
    for (int k = 0; k < 3; ++k) target[k] += rng.uniform(-kTargetJitter, kTargetJitter);
    Camera cam;
    cam.name = fmt::format("cam{:02d}", i);
    cam.width = o.width;
    cam.height = o.height;
    cam.fx = cam.fy = fx;
    cam.cx = 0.5 * o.width;
    cam.cy = 0.5 * o.height;
    cam.world_to_camera = look_at(eye, target, Vector3d(0, -1, 0));
    cameras.push_back(cam);
  }
  return cameras;
}

// World rays of one camera without re-deriving its centre and rotation per pixel.
struct Rays {
  explicit Rays(const Camera& camera)
      : cam(camera), origin(camera.center()), camera_to_world(camera.rotation().transpose()) {}
  Vector3d direction(double u, double v) const {
    return (camera_to_world * Vector3d((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1))
        .normalized();
  }
  const Camera& cam;
  Vector3d origin;
  Eigen::Matrix3d camera_to_world;
};

// One view at one frame: the supersampled image and mask, and what each pixel centre sees (the
// start of the flows from this frame).
struct View {
  Image image;                     // [H, W, 3]
  Image mask;                      // [H, W, 1] fraction of foreground supersamples
  std::vector<int> centre_object;  // [H, W] object hit by the ray through the pixel centre
  std::vector<double> centre_u;    // [H, W, 3] its canonical coordinate
};

View render_view(const World& world, const Posed& posed, const Rays& rays, int supersample) {
  const int w = rays.cam.width, h = rays.cam.height;
  View view{Image(w, h, 3), Image(w, h, 1), std::vector<int>(std::size_t(w) * h),
            std::vector<double>(std::size_t(w) * h * 3)};
  const double weight = 1.0 / (supersample * supersample);
#pragma omp parallel for schedule(dynamic)
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      Vector3d colour = Vector3d::Zero();
      int covered = 0;
      for (int j = 0; j < supersample; ++j) {
        for (int i = 0; i < supersample; ++i) {
          const Hit hit = synth::cast_ray(
              world, posed, rays.origin,
              rays.direction(x + (i + 0.5) / supersample, y + (j + 0.5) / supersample));
          colour += synth::shade(world, posed, hit);
          covered += world.objects[hit.object].foreground;
        }
      }
      const std::size_t p = std::size_t(y) * w + x;
      for (int c = 0; c < 3; ++c) view.image.data[p * 3 + c] = float(weight * colour[c]);
      view.mask.data[p] = float(weight * covered);
      const Hit centre =
          synth::cast_ray(world, posed, rays.origin, rays.direction(x + 0.5, y + 0.5));
      view.centre_object[p] = centre.object;
      for (int c = 0; c < 3; ++c) view.centre_u[p * 3 + c] = centre.u[c];
    }
  }
  return view;
}

// Exact flow from the view's frame to the frame posed in `to`: each pixel centre's surface point
// keeps its canonical coordinate, moves to the world at `to` and is projected; unknown where it
// leaves the image or something else (or the object's own front side) is seen there.
Flow exact_flow(const World& world, const Posed& to, const Rays& rays, const View& from) {
  const int w = rays.cam.width, h = rays.cam.height;
  Flow flow(w, h);
#pragma omp parallel for schedule(dynamic)
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const std::size_t p = std::size_t(y) * w + x;
      const int object = from.centre_object[p];
      const Vector3d u(from.centre_u[p * 3], from.centre_u[p * 3 + 1], from.centre_u[p * 3 + 2]);
      const Vector3d target = synth::canonical_to_world(to, object, u);
      const Vector3d target_cam = rays.cam.world_to_cam(target);
      // Cameras are static, so a static surface stays at its pixel exactly.
      const Vector2d uv = world.objects[object].motion.is_static()
                              ? Vector2d(x + 0.5, y + 0.5)
                              : rays.cam.project_cam(target_cam);
      bool visible = target_cam.z() > 0 && rays.cam.in_image(uv);
      if (visible) {
        const double expected = (target - rays.origin).norm();
        const Hit hit = synth::cast_ray(world, to, rays.origin, rays.direction(uv.x(), uv.y()));
        visible =
            hit.object == object && std::abs(hit.distance - expected) <= kDepthTolerance * expected;
      }
      flow.valid[p] = visible;
      flow.uv[p * 2] = visible ? float(uv.x() - (x + 0.5)) : 0.0f;
      flow.uv[p * 2 + 1] = visible ? float(uv.y() - (y + 0.5)) : 0.0f;
    }
  }
  return flow;
}

// Uniform samples of every moving object's surface, the ground around the stage, and sparse
// samples of the far ground and the sky dome, each kept only where at least one camera sees it,
// coloured with the albedo.
io::PointCloud frame_points(const World& world, const Posed& posed,
                            const std::vector<Camera>& cameras, std::uint64_t seed, int frame) {
  synth::Rng rng(synth::stream_seed(seed, synth::kPointStream + std::uint64_t(frame)));
  io::PointCloud points;
  auto seen = [&](const Vector3d& x) {
    return std::any_of(cameras.begin(), cameras.end(), [&](const Camera& cam) {
      const Vector3d xc = cam.world_to_cam(x);
      return xc.z() > 0 && cam.in_image(cam.project_cam(xc));
    });
  };
  auto emit = [&](const Vector3d& x, const Vector3d& c) {
    for (int k = 0; k < 3; ++k) {
      points.xyz.push_back(float(x[k]));
      points.rgb.push_back(float(c[k]));
    }
  };
  // Ground radius inside the dome (the dome meets the ground plane at this radius).
  const double ground_edge = 0.95 * world.sky_radius;
  for (int i = 0; i < int(world.objects.size()); ++i) {
    const synth::Object& object = world.objects[i];
    if (object.shape == synth::Shape::kPlane) {
      const long near = std::lround(kGroundPointDensity * std::numbers::pi * kGroundPointRadius *
                                    kGroundPointRadius);
      for (long n = 0; n < near + kFarGroundPoints; ++n) {
        // Uniform over the stage disc, then uniform over the ring out to the dome.
        const double r = n < near ? kGroundPointRadius * std::sqrt(rng.uniform())
                                  : std::sqrt(rng.uniform(kGroundPointRadius * kGroundPointRadius,
                                                          ground_edge * ground_edge));
        const double phi = rng.uniform(0, 2 * std::numbers::pi);
        const Vector3d x(r * std::cos(phi), 0, r * std::sin(phi));
        if (seen(x)) emit(x, synth::albedo(object.texture, x));
      }
    } else if (object.emissive) {
      // The sky: directions of the upper hemisphere (world up is -y) on the dome.
      for (long n = 0; n < kSkyPoints; ++n) {
        const double y = rng.uniform(-1, 0), phi = rng.uniform(0, 2 * std::numbers::pi);
        const double r = std::sqrt(std::max(0.0, 1 - y * y));
        const Vector3d u(r * std::cos(phi), y, r * std::sin(phi));
        const Vector3d x = world.sky_radius * u;
        if (seen(x)) emit(x, synth::albedo(object.texture, u));
      }
    } else if (object.foreground) {
      synth::sample_surface(world, posed, i, kObjectPointDensity, rng, points);
    }
  }
  return points;
}

}  // namespace

void synthesize_scene(const SynthOptions& options, const std::filesystem::path& out) {
  validate(options);
  const World world = synth::build_world(options.preset, options.seed, options.frames);
  const int cameras = options.cameras, frames = options.frames;

  AtomicDirectory dir(out, options.force);
  io::Scene scene;
  scene.root = dir.temp_path();
  scene.num_frames = frames;
  scene.fps = options.fps;
  scene.cameras = make_cameras(options, world);
  scene.up = Vector3d(0, -1, 0);
  scene.clocks = make_clocks(options, scene.cameras);
  io::Scene recorded = scene;  // what scene.json says; the images follow `scene`
  if (!options.record_offsets) recorded.clocks.clear();
  if (options.perturb_calibration)
    io::write_perturbed_scene(recorded, *options.perturb_calibration, options.seed);
  else
    io::write_scene_json(recorded);

  std::vector<Posed> posed;  // [K], at the scene's frame times (the points')
  for (int k = 0; k < frames; ++k) posed.push_back(synth::pose_world(world, k));

  // Flows of strides 1 and 2 in both directions (docs/formats.md file names).
  constexpr int kStrides[] = {-2, -1, 1, 2};
  Progress progress("synth", std::size_t(cameras) * frames, options.progress);
  for (int c = 0; c < cameras; ++c) {
    const Rays rays(scene.cameras[c]);
    // The camera's own frame times (those of `posed` without an offset).
    std::vector<Posed> own;
    const bool own_clock = io::frame_time(scene, c, 0) != 0;
    if (own_clock)
      for (int k = 0; k < frames; ++k)
        own.push_back(synth::pose_world(world, io::frame_time(scene, c, k)));
    const std::vector<Posed>& at = own_clock ? own : posed;
    for (int k = 0; k < frames; ++k) {
      const View view = render_view(world, at[k], rays, options.supersample);
      media::write_png(scene.image_path(c, k), view.image);
      media::write_png(scene.mask_path(c, k), view.mask);
      for (int stride : kStrides) {
        const int to = k + stride;
        if (to < 0 || to >= frames) continue;
        io::write_flo(scene.flow_path(c, k, to), exact_flow(world, at[to], rays, view));
      }
      progress.tick();
    }
  }
  for (int k = 0; k < frames; ++k)
    io::write_points_ply(scene.points_path(k),
                         frame_points(world, posed[k], scene.cameras, options.seed, k));
  progress.finish();
  dir.commit();
}

}  // namespace retimegs::synth
