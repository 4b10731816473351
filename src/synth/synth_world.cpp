#include "synth_world.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <Eigen/Geometry>

#include "retimegs/core/error.hpp"
#include "retimegs/synth/synth.hpp"

namespace retimegs::synth::synth {

using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {

constexpr double kPi = std::numbers::pi;
// Rays start at camera centres, never on a surface; this only rejects hits behind the origin.
constexpr double kMinDistance = 1e-6;
// Seed-dependent jitter of preset parameters: small enough that every preset keeps its character
// (speeds, layout), large enough that two seeds give visibly different scenes.
constexpr double kColourJitter = 0.06;
constexpr double kFrequencyJitter = 0.15;  // relative

double smoothstep(double edge0, double edge1, double x) {
  const double s = std::clamp((x - edge0) / (edge1 - edge0), 0.0, 1.0);
  return s * s * (3 - 2 * s);
}

Vector3d mix(const Vector3d& a, const Vector3d& b, double w) {
  return a + w * (b - a);
}

Vector3d jitter_colour(const Vector3d& colour, Rng& rng) {
  Vector3d c;
  for (int i = 0; i < 3; ++i)
    c[i] = std::clamp(colour[i] + rng.uniform(-kColourJitter, kColourJitter), 0.02, 0.98);
  return c;
}

Texture make_texture(Pattern pattern, const Vector3d& a, const Vector3d& b, double frequency,
                     Rng& rng) {
  Texture t;
  t.pattern = pattern;
  t.colour_a = jitter_colour(a, rng);
  t.colour_b = jitter_colour(b, rng);
  t.frequency = frequency * rng.uniform(1 - kFrequencyJitter, 1 + kFrequencyJitter);
  t.phase = {rng.uniform(0, 2 * kPi), rng.uniform(0, 2 * kPi), rng.uniform(0, 2 * kPi)};
  return t;
}

// Static backdrop shared by every preset: a tiled ground plane y = 0 and a sky dome.
void add_backdrop(World& world, Rng& rng) {
  Object ground;
  ground.shape = Shape::kPlane;
  ground.foreground = false;
  // Tiles 0.5 m wide (sin period 1 m): several pixels each across the whole visible ground.
  ground.texture =
      make_texture(Pattern::kTiles, {0.62, 0.56, 0.46}, {0.34, 0.31, 0.27}, kPi / 0.5, rng);
  world.objects.push_back(ground);

  Object sky;
  sky.shape = Shape::kSphere;
  sky.foreground = false;
  sky.emissive = true;
  sky.motion.radii = Vector3d::Constant(world.sky_radius);
  sky.texture = make_texture(Pattern::kSky, {0.30, 0.50, 0.88}, {0.30, 0.36, 0.33}, 3.0, rng);
  world.objects.push_back(sky);
}

// The preset objects. `speed` multiplies every rate (the "fast" preset doubles them).
Object orbiter(Rng& rng, double orbit_radius, double radius, double orbit_rate, double bob,
               double speed) {
  Object o;
  o.shape = Shape::kSphere;
  o.motion.anchor = {0, -0.78, 0};
  o.motion.orbit_radius = orbit_radius;
  o.motion.orbit_rate = orbit_rate * speed;
  o.motion.orbit_phase = rng.uniform(0, 2 * kPi);
  o.motion.bob_amplitude = bob;
  o.motion.spin_axis = Vector3d(0.3, 1.0, 0.2).normalized();
  o.motion.spin_rate = 0.1 * speed;
  o.motion.spin_phase = rng.uniform(0, 2 * kPi);
  o.motion.radii = Vector3d::Constant(radius);
  o.texture = make_texture(Pattern::kSpots, {0.86, 0.24, 0.14}, {0.96, 0.84, 0.30}, 4.5, rng);
  return o;
}

Object spinner(Rng& rng, const Vector3d& anchor, const Vector3d& half_size, double speed) {
  Object o;
  o.shape = Shape::kBox;
  o.motion.anchor = anchor;
  // About the vertical: the box keeps standing on the ground.
  o.motion.spin_axis = Vector3d::UnitY();
  o.motion.spin_rate = 0.15 * speed;
  o.motion.spin_phase = rng.uniform(0, 2 * kPi);
  o.motion.radii = half_size;
  o.texture = make_texture(Pattern::kSpots, {0.14, 0.34, 0.80}, {0.86, 0.90, 0.95}, 4.0, rng);
  return o;
}

World make_default(std::uint64_t seed, int frames, double speed) {
  World world;
  world.frames = frames;
  Rng rng(stream_seed(seed, kWorldStream));
  add_backdrop(world, rng);

  // 0.25 rad/frame on a 1.55 m circle: ~0.39 m per frame, >= 15 px per frame at 256 px width
  // from the farthest point of the ring of cameras 4.5 m away, when the motion is across the view.
  world.objects.push_back(orbiter(rng, 1.55, 0.28, 0.25, 0.22, speed));

  const Vector3d box_anchor(0.35, -0.46, 0.25);
  world.objects.push_back(spinner(rng, box_anchor, {0.30, 0.45, 0.30}, speed));

  Object breather;
  breather.shape = Shape::kSphere;
  breather.motion.anchor = {-0.65, -0.62, -0.35};
  breather.motion.spin_rate = 0.05 * speed;
  breather.motion.spin_phase = rng.uniform(0, 2 * kPi);
  breather.motion.radii = {0.30, 0.42, 0.26};
  breather.motion.pulse_amplitude = {0.22, 0.18, 0.25};
  breather.motion.pulse_rate = 0.35 * speed;
  breather.motion.pulse_phase = {rng.uniform(0, 2 * kPi), rng.uniform(0, 2 * kPi),
                                 rng.uniform(0, 2 * kPi)};
  breather.texture =
      make_texture(Pattern::kSpots, {0.20, 0.70, 0.30}, {0.06, 0.26, 0.10}, 5.0, rng);
  world.objects.push_back(breather);

  // Starts inside the box (hidden from every camera) and slides out of it, upwards and along -z.
  Object emerger;
  emerger.shape = Shape::kSphere;
  emerger.motion.anchor = box_anchor;
  emerger.motion.slide = {0.15, -0.55, -0.60};
  emerger.motion.slide_begin = 0.1;
  emerger.motion.slide_end = 0.1 + 0.7 / speed;
  emerger.motion.spin_axis = Vector3d::UnitX();
  emerger.motion.spin_rate = 0.1 * speed;
  emerger.motion.radii = Vector3d::Constant(0.19);
  emerger.texture = make_texture(Pattern::kSpots, {0.80, 0.20, 0.70}, {0.15, 0.10, 0.22}, 5.0, rng);
  world.objects.push_back(emerger);
  return world;
}

// Static objects covered in multi-scale noise over a noise-textured ground: many distinct SIFT
// features in every view, at many depths, for camera calibration from the images (`import
// videos` without a calibration). Noise cells of 10 cm on the objects, 17 cm on the ground: 7 and
// 12 pixels at 320 pixels wide from the ring of cameras.
World make_textured(std::uint64_t seed, int frames) {
  World world;
  world.frames = frames;
  Rng rng(stream_seed(seed, kWorldStream));
  add_backdrop(world, rng);
  constexpr double kObjectCellsPerMetre = 10, kGroundCellsPerMetre = 6;
  world.objects[0].texture = make_texture(Pattern::kNoise, {0.92, 0.86, 0.74}, {0.12, 0.10, 0.08},
                                          kGroundCellsPerMetre, rng);
  // Boxes standing on the ground and spheres resting on it, around the centre and on a ring
  // 1.7 m out, so that every view has objects near and far.
  struct Placed {
    Shape shape;
    Vector3d anchor, radii, colour_a, colour_b;
  };
  const Placed placed[] = {
      {Shape::kBox, {0, -0.5, 0}, {0.5, 0.5, 0.5}, {0.95, 0.90, 0.80}, {0.10, 0.15, 0.45}},
      {Shape::kBox, {1.7, -0.8, 0}, {0.25, 0.8, 0.25}, {0.90, 0.30, 0.20}, {0.95, 0.95, 0.85}},
      {Shape::kBox, {-1.7, -0.6, 0}, {0.3, 0.6, 0.3}, {0.20, 0.30, 0.90}, {0.95, 0.85, 0.60}},
      {Shape::kBox, {0, -0.7, 1.7}, {0.3, 0.7, 0.2}, {0.95, 0.80, 0.10}, {0.10, 0.30, 0.15}},
      {Shape::kBox, {0, -0.5, -1.7}, {0.35, 0.5, 0.35}, {0.70, 0.20, 0.70}, {0.95, 0.95, 0.90}},
      {Shape::kSphere, {1.2, -0.4, 1.2}, {0.4, 0.4, 0.4}, {0.15, 0.60, 0.25}, {0.95, 0.95, 0.70}},
      {Shape::kSphere,
       {-1.2, -0.35, -1.2},
       {0.35, 0.35, 0.35},
       {0.85, 0.80, 0.20},
       {0.20, 0.10, 0.30}},
      {Shape::kSphere,
       {-1.2, -0.45, 1.2},
       {0.45, 0.45, 0.45},
       {0.90, 0.50, 0.10},
       {0.05, 0.05, 0.05}},
      {Shape::kSphere, {1.2, -0.3, -1.2}, {0.3, 0.3, 0.3}, {0.10, 0.70, 0.80}, {0.98, 0.98, 0.98}},
  };
  for (const Placed& p : placed) {
    Object o;
    o.shape = p.shape;
    o.motion.anchor = p.anchor;
    o.motion.radii = p.radii;
    // Frequencies are per canonical unit: scaled by the size, cells stay ~10 cm on every object.
    o.texture = make_texture(Pattern::kNoise, p.colour_a, p.colour_b,
                             kObjectCellsPerMetre * p.radii.mean(), rng);
    world.objects.push_back(o);
  }
  return world;
}

// Motion whose strength over time looks alike from every camera of the ring: on the vertical
// through the point the cameras look at, a sphere that swells and shrinks with the same phase on
// every axis, and above it one that rises and stops. Synchronising cameras from their motion
// energy (`import videos --sync auto`) needs that; an object going round (the default preset's)
// moves fastest across the view of a different camera at each moment, and objects off the axis
// weigh differently in each view, so those cameras' motion energies do not match.
World make_pulsing(std::uint64_t seed, int frames) {
  World world;
  world.frames = frames;
  Rng rng(stream_seed(seed, kWorldStream));
  add_backdrop(world, rng);
  Object pulsing;
  pulsing.shape = Shape::kSphere;
  pulsing.motion.anchor = {0, -0.6, 0};
  pulsing.motion.radii = Vector3d::Constant(0.45);
  pulsing.motion.pulse_amplitude = Vector3d::Constant(0.3);
  pulsing.motion.pulse_rate = rng.uniform(0.27, 0.33);  // a period of about 21 frames
  pulsing.motion.pulse_phase = Vector3d::Constant(rng.uniform(0, 2 * kPi));
  pulsing.texture = make_texture(Pattern::kSpots, {0.86, 0.24, 0.14}, {0.96, 0.84, 0.30}, 4.5, rng);
  world.objects.push_back(pulsing);
  return world;
}

World make_minimal(std::uint64_t seed, int frames) {
  World world;
  world.frames = frames;
  Rng rng(stream_seed(seed, kWorldStream));
  add_backdrop(world, rng);
  world.objects.push_back(orbiter(rng, 1.2, 0.3, 0.15, 0.15, 1.0));
  world.objects.push_back(spinner(rng, {0, -0.36, 0}, Vector3d::Constant(0.35), 1.0));
  return world;
}

// Knud Thomsen's approximation of an ellipsoid's area (within 1.1 %); only sets sample counts.
double ellipsoid_area(const Vector3d& r) {
  constexpr double p = 1.6075;
  const double a = std::pow(r.x(), p), b = std::pow(r.y(), p), c = std::pow(r.z(), p);
  return 4 * kPi * std::pow((a * b + a * c + b * c) / 3, 1 / p);
}

}  // namespace

std::uint64_t Rng::next() {
  std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

double Rng::uniform() {
  return double(next() >> 11) * 0x1.0p-53;
}

std::uint64_t stream_seed(std::uint64_t seed, std::uint64_t stream) {
  Rng rng(seed ^ (stream * 0xd1b54a32d192ed03ULL));
  return rng.next();
}

bool Motion::is_static() const {
  return orbit_rate == 0 && spin_rate == 0 && slide.isZero(0) &&
         (pulse_amplitude.isZero(0) || pulse_rate == 0);
}

}  // namespace retimegs::synth::synth

namespace retimegs::synth {

const std::vector<SynthPreset>& synth_presets() {
  static const std::vector<SynthPreset> presets = {
      {"default",
       "a fast sphere on a curved path, a spinning box, a breathing ellipsoid and a sphere "
       "emerging from the box, over a tiled ground under a sky"},
      {"fast", "the default objects with twice the motion (a hard case for interpolation)"},
      {"minimal", "one textured sphere on a circular path and one spinning box (tiny tests)"},
      {"pulsing",
       "a sphere that swells and shrinks and one that rises and stops above it, alike from every "
       "camera (synchronising cameras from their footage)"},
      {"textured",
       "static boxes and spheres covered in multi-scale noise over a noise-textured ground (camera "
       "calibration from the images)"},
  };
  return presets;
}

}  // namespace retimegs::synth

namespace retimegs::synth::synth {

World build_world(const std::string& preset, std::uint64_t seed, int frames) {
  if (preset == "default") return make_default(seed, frames, 1.0);
  if (preset == "fast") return make_default(seed, frames, 2.0);
  if (preset == "minimal") return make_minimal(seed, frames);
  if (preset == "textured") return make_textured(seed, frames);
  if (preset == "pulsing") return make_pulsing(seed, frames);
  std::string known;
  for (const auto& p : synth_presets()) known += (known.empty() ? "" : ", ") + p.name;
  fail("--preset: unknown preset '{}' (presets: {})", preset, known);
}

Posed pose_world(const World& world, double t) {
  Posed posed;
  const double clip = world.frames > 1 ? t / (world.frames - 1) : 0.0;
  for (const Object& object : world.objects) {
    const Motion& m = object.motion;
    const double angle = m.orbit_phase + m.orbit_rate * t;
    Vector3d centre = m.anchor;
    centre += m.orbit_radius * Vector3d(std::cos(angle), 0, std::sin(angle));
    centre.y() += m.bob_amplitude * std::sin(2 * angle);
    centre += m.slide * smoothstep(m.slide_begin, m.slide_end, clip);
    const Matrix3d rotation =
        Eigen::AngleAxisd(m.spin_phase + m.spin_rate * t, m.spin_axis.normalized())
            .toRotationMatrix();
    Vector3d scale;
    for (int i = 0; i < 3; ++i)
      scale[i] =
          m.radii[i] * (1 + m.pulse_amplitude[i] * std::sin(m.pulse_rate * t + m.pulse_phase[i]));
    posed.linear.push_back(rotation * scale.asDiagonal());
    posed.inverse.push_back(scale.cwiseInverse().asDiagonal() * rotation.transpose());
    posed.centre.push_back(centre);
  }
  return posed;
}

Vector3d canonical_to_world(const Posed& posed, int object, const Vector3d& u) {
  return posed.centre[object] + posed.linear[object] * u;
}

Hit cast_ray(const World& world, const Posed& posed, const Vector3d& origin,
             const Vector3d& direction) {
  Hit best;
  best.distance = std::numeric_limits<double>::infinity();
  for (int i = 0; i < int(world.objects.size()); ++i) {
    // The affine map keeps the ray parameter: canonical o + s d is world origin + s direction.
    const Vector3d o = posed.inverse[i] * (origin - posed.centre[i]);
    const Vector3d d = posed.inverse[i] * direction;
    double s = 0;
    Vector3d normal = Vector3d::Zero();  // canonical outward normal at the hit
    switch (world.objects[i].shape) {
      case Shape::kSphere: {
        const double a = d.squaredNorm(), b = o.dot(d), c = o.squaredNorm() - 1;
        const double disc = b * b - a * c;
        if (disc < 0) continue;
        const double root = std::sqrt(disc);
        const double near = (-b - root) / a, far = (-b + root) / a;
        s = near > kMinDistance ? near : far;  // far: seen from inside (the sky dome)
        if (!(s > kMinDistance && s < best.distance)) continue;
        normal = o + s * d;
        break;
      }
      case Shape::kBox: {
        double enter = -std::numeric_limits<double>::infinity();
        double leave = std::numeric_limits<double>::infinity();
        int axis = -1;
        bool miss = false;
        for (int k = 0; k < 3 && !miss; ++k) {
          if (d[k] == 0) {
            miss = std::abs(o[k]) > 1;
            continue;
          }
          double t0 = (-1 - o[k]) / d[k], t1 = (1 - o[k]) / d[k];
          if (t0 > t1) std::swap(t0, t1);
          if (t0 > enter) enter = t0, axis = k;
          leave = std::min(leave, t1);
        }
        // Cameras are never inside a box, so only the entry face is visible.
        if (miss || axis < 0 || enter > leave || !(enter > kMinDistance && enter < best.distance))
          continue;
        s = enter;
        normal[axis] = d[axis] > 0 ? -1 : 1;
        break;
      }
      case Shape::kPlane: {
        if (d.y() == 0) continue;
        s = -o.y() / d.y();
        if (!(s > kMinDistance && s < best.distance)) continue;
        normal = Vector3d(0, -1, 0);  // up (world up is -y); the cameras are all above the ground
        break;
      }
    }
    best.object = i;
    best.distance = s;
    best.u = o + s * d;
    if (world.objects[i].shape == Shape::kBox) {
      // Snap the entry face coordinate onto the surface exactly.
      for (int k = 0; k < 3; ++k)
        if (normal[k] != 0) best.u[k] = normal[k];
    } else if (world.objects[i].shape == Shape::kPlane) {
      best.u.y() = 0;
    }
    best.normal = normal;
  }
  return best;
}

namespace {

// Value noise: a hash of the lattice cell in [0, 1), interpolated trilinearly with smoothstep
// weights (continuous, so that supersampling converges).
double lattice_value(std::int64_t x, std::int64_t y, std::int64_t z) {
  Rng rng(std::uint64_t(x) * 0x9e3779b97f4a7c15ULL ^ std::uint64_t(y) * 0xc2b2ae3d27d4eb4fULL ^
          std::uint64_t(z) * 0x165667b19e3779f9ULL);
  return rng.uniform();
}

double value_noise(const Vector3d& x) {
  const Vector3d f = x.array().floor();
  const Vector3d w = (x - f).unaryExpr([](double v) { return v * v * (3 - 2 * v); });
  const auto i = f.cast<std::int64_t>();
  double sum = 0;
  for (int corner = 0; corner < 8; ++corner) {
    const int dx = corner & 1, dy = (corner >> 1) & 1, dz = corner >> 2;
    const double weight =
        (dx ? w.x() : 1 - w.x()) * (dy ? w.y() : 1 - w.y()) * (dz ? w.z() : 1 - w.z());
    sum += weight * lattice_value(i.x() + dx, i.y() + dy, i.z() + dz);
  }
  return sum;
}

}  // namespace

Vector3d albedo(const Texture& t, const Vector3d& u) {
  const double f = t.frequency;
  const Vector3d& p = t.phase;
  switch (t.pattern) {
    case Pattern::kSpots: {
      // A sum (not a product) of waves, so flat box faces where one coordinate is constant
      // still get full-contrast blobs.
      const double s =
          std::sin(f * u.x() + p.x()) + std::sin(f * u.y() + p.y()) + std::sin(f * u.z() + p.z());
      const double blobs = smoothstep(-0.5, 0.5, s);
      const double stripes = 0.5 + 0.5 * std::sin(2.2 * f * (u.x() - u.y() + u.z()) + p.x());
      return mix(t.colour_a, t.colour_b, blobs) * (0.85 + 0.15 * stripes);
    }
    case Pattern::kTiles: {
      // Tiles fade out beyond 4 m where they would alias at grazing angles.
      const double s = std::sin(f * u.x() + p.x()) * std::sin(f * u.z() + p.z());
      const double fade = 1 - smoothstep(4.0, 8.0, std::hypot(u.x(), u.z()));
      const double w = 0.5 + (smoothstep(-0.25, 0.25, s) - 0.5) * fade;
      const double tint =
          0.92 + 0.08 * std::sin(0.8 * u.x() + p.y()) * std::sin(0.6 * u.z() + p.y());
      return mix(t.colour_a, t.colour_b, w) * tint;
    }
    case Pattern::kSky: {
      const Vector3d horizon(0.85, 0.88, 0.92), cloud(0.97, 0.97, 0.97);
      const double elevation = -u.y();  // sine of the elevation angle (up is -y)
      Vector3d sky = mix(horizon, t.colour_a, smoothstep(0.0, 0.5, elevation));
      const double c = std::sin(f * u.x() + p.x()) * std::sin(1.3 * f * u.z() + p.y()) +
                       0.5 * std::sin(2.1 * f * u.x() - 1.7 * f * u.z() + p.z());
      sky = mix(sky, cloud, 0.8 * smoothstep(0.4, 1.1, c) * smoothstep(0.05, 0.2, elevation));
      // Mountain skyline: integer multiples of the azimuth keep it continuous all around.
      const double az = std::atan2(u.z(), u.x());
      const double ridge = 0.07 + 0.035 * std::sin(3 * az + p.x()) +
                           0.02 * std::sin(7 * az + p.z()) + 0.01 * std::sin(13 * az + p.y());
      const double rock = 1 - smoothstep(ridge - 0.004, ridge + 0.004, elevation);
      const Vector3d mountain = t.colour_b * (0.75 + 0.25 * smoothstep(0.0, ridge, elevation));
      return mix(sky, mountain, rock);
    }
    case Pattern::kNoise: {
      // Two octaves (cells 1 and 1/2 of 1/frequency), then a steep contrast curve: blobs with
      // sharp edges at two scales.
      const Vector3d x = f * u + p;
      const double n = (value_noise(x) + 0.5 * value_noise(2 * x + p)) / 1.5;
      return mix(t.colour_a, t.colour_b, smoothstep(0.4, 0.6, n));
    }
  }
  return t.colour_a;
}

Vector3d shade(const World& world, const Posed& posed, const Hit& hit) {
  const Object& object = world.objects[hit.object];
  const Vector3d a = albedo(object.texture, hit.u);
  if (object.emissive) return a;
  // Normals map with the inverse transpose of R diag(S).
  const Vector3d n = (posed.inverse[hit.object].transpose() * hit.normal).normalized();
  const double lambert = std::max(0.0, n.dot(world.light));
  return a * (world.ambient + (1 - world.ambient) * lambert);
}

void sample_surface(const World& world, const Posed& posed, int object, double density, Rng& rng,
                    io::PointCloud& points) {
  const Object& o = world.objects[object];
  const Vector3d scale = posed.linear[object].colwise().norm();  // S: R has unit columns
  auto emit = [&](const Vector3d& u) {
    const Vector3d x = canonical_to_world(posed, object, u);
    const Vector3d c = albedo(o.texture, u);
    for (int k = 0; k < 3; ++k) {
      points.xyz.push_back(float(x[k]));
      points.rgb.push_back(float(c[k]));
    }
  };
  switch (o.shape) {
    case Shape::kSphere: {
      // Uniform directions, kept with probability proportional to the world area element
      // det(S) |S^-1 u| (largest det(S) / min(S)): uniform over the ellipsoid.
      const long count = std::lround(density * ellipsoid_area(scale));
      const double min_radius = scale.minCoeff();
      for (long n = 0; n < count;) {
        const double z = rng.uniform(-1, 1), phi = rng.uniform(0, 2 * kPi);
        const double r = std::sqrt(std::max(0.0, 1 - z * z));
        const Vector3d u(r * std::cos(phi), r * std::sin(phi), z);
        if (rng.uniform() >= min_radius * u.cwiseQuotient(scale).norm()) continue;
        emit(u);
        ++n;
      }
      break;
    }
    case Shape::kBox: {
      // Face pair k has world area 2 * 4 S_i S_j; pick it with that probability.
      const Vector3d face_area(scale.y() * scale.z(), scale.x() * scale.z(), scale.x() * scale.y());
      const double total = face_area.sum();
      const long count = std::lround(density * 8 * total);
      for (long n = 0; n < count; ++n) {
        const double pick = rng.uniform() * total;
        const int axis = pick < face_area.x() ? 0 : pick < face_area.x() + face_area.y() ? 1 : 2;
        Vector3d u(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        u[axis] = rng.uniform() < 0.5 ? -1 : 1;
        emit(u);
      }
      break;
    }
    case Shape::kPlane:
      break;
  }
}

}  // namespace retimegs::synth::synth
