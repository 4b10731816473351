#pragma once
// The analytic world behind `retimegs synth` (private to src/synth). Every object maps canonical
// coordinates u (the unit sphere, the surface of the cube [-1, 1]^3, or the plane y = 0) to the
// world at time t by X(t) = C(t) + R(t) diag(S(t)) u, with closed-form C, R, S. Rays are
// intersected in canonical space and textures are functions of u, so a surface point keeps its
// canonical coordinate while it moves and flows are exact. Shares no code with any splat renderer.
// Times are in scene frame units (frame k at t = k).
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "retimegs/io/ply.hpp"

namespace retimegs::synth::synth {

// splitmix64: a tiny generator whose output is fixed by the standard (unlike std::*_distribution),
// so scenes are byte-identical across compilers and standard libraries.
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next();
  double uniform();  // [0, 1)
  double uniform(double a, double b) { return a + (b - a) * uniform(); }

 private:
  std::uint64_t state_;
};

// Independent streams of one seed: world parameters, camera jitter, the points of a frame.
std::uint64_t stream_seed(std::uint64_t seed, std::uint64_t stream);
constexpr std::uint64_t kWorldStream = 1;
constexpr std::uint64_t kCameraStream = 2;
constexpr std::uint64_t kPointStream = 3;  // + frame index

enum class Shape {
  kSphere,  // |u| = 1
  kBox,     // surface of [-1, 1]^3
  kPlane,   // u.y = 0 (the ground; canonical = world)
};

enum class Pattern {
  kSpots,  // soft blobs and fine stripes in 3-D canonical space (spheres, boxes, ellipsoids)
  kTiles,  // soft checker on the ground, fading to plain with distance from the scene centre
  kSky,    // gradient, clouds and a mountain skyline as a function of direction
  kNoise,  // hard-edged multi-scale value noise in 3-D canonical space (corners at every scale)
};

struct Texture {
  Pattern pattern = Pattern::kSpots;
  Eigen::Vector3d colour_a{0.5, 0.5, 0.5}, colour_b{0.5, 0.5, 0.5};  // albedo in [0, 1]
  double frequency = 1;                                              // radians per canonical unit
  Eigen::Vector3d phase = Eigen::Vector3d::Zero();                   // radians
};

// X(t) = C(t) + R(t) diag(S(t)) u with
//   C(t) = anchor + orbit_radius (cos a, 0, sin a) + (0, bob_amplitude sin 2a, 0)
//          + slide * smoothstep(slide_begin, slide_end, t / (frames - 1))
//   a    = orbit_phase + orbit_rate t
//   R(t) = rotation by spin_phase + spin_rate t about spin_axis
//   S(t) = radii * (1 + pulse_amplitude * sin(pulse_rate t + pulse_phase))   (per axis)
// Rates are per frame; the slide is clip-relative so that it happens within any clip length.
struct Motion {
  Eigen::Vector3d anchor = Eigen::Vector3d::Zero();
  double orbit_radius = 0, orbit_rate = 0, orbit_phase = 0;
  double bob_amplitude = 0;
  Eigen::Vector3d slide = Eigen::Vector3d::Zero();
  double slide_begin = 0, slide_end = 1;
  Eigen::Vector3d spin_axis = Eigen::Vector3d::UnitY();
  double spin_rate = 0, spin_phase = 0;
  Eigen::Vector3d radii = Eigen::Vector3d::Ones();
  Eigen::Vector3d pulse_amplitude = Eigen::Vector3d::Zero();
  double pulse_rate = 0;
  Eigen::Vector3d pulse_phase = Eigen::Vector3d::Zero();

  bool is_static() const;
};

struct Object {
  Shape shape = Shape::kSphere;
  bool foreground = true;  // counted in the masks (every moving object)
  bool emissive = false;   // unshaded (the sky)
  Motion motion;
  Texture texture;
};

struct World {
  std::vector<Object> objects;
  int frames = 2;  // clip length (for clip-relative motion)
  // Unit vector toward the light: above (up is -y) and to one side, so box faces differ.
  Eigen::Vector3d light = Eigen::Vector3d(0.45, -1.0, 0.3).normalized();
  // Fraction of the albedo lit regardless of orientation: high enough that turning objects change
  // brightness only mildly (flows stay checkable by warping), low enough to show their shape.
  double ambient = 0.45;
  Eigen::Vector3d centre{0, -0.45, 0};  // where the cameras look
  double sky_radius = 14;               // radius of the sky dome around the origin
};

// The objects of a preset (see synth_presets()) with seed-dependent phases, colours and texture
// parameters. Throws Error on an unknown preset.
World build_world(const std::string& preset, std::uint64_t seed, int frames);

// Every object posed at one time (structure of arrays over objects).
struct Posed {
  std::vector<Eigen::Matrix3d> linear;   // [O] R diag(S): canonical -> world (without C)
  std::vector<Eigen::Matrix3d> inverse;  // [O] diag(1/S) R^T: world -> canonical
  std::vector<Eigen::Vector3d> centre;   // [O] C
};
Posed pose_world(const World& world, double t);

Eigen::Vector3d canonical_to_world(const Posed& posed, int object, const Eigen::Vector3d& u);

struct Hit {
  int object = -1;                                   // -1: nothing (impossible inside the sky)
  double distance = 0;                               // along the unit ray direction
  Eigen::Vector3d u = Eigen::Vector3d::Zero();       // canonical coordinate of the hit
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // canonical outward normal
};

// Nearest intersection with distance > 0 of the ray origin + s * direction (|direction| = 1).
Hit cast_ray(const World& world, const Posed& posed, const Eigen::Vector3d& origin,
             const Eigen::Vector3d& direction);

Eigen::Vector3d albedo(const Texture& texture, const Eigen::Vector3d& u);  // RGB in [0, 1]

// Lambert + ambient with the world's fixed light (emissive objects: their albedo).
Eigen::Vector3d shade(const World& world, const Posed& posed, const Hit& hit);

// Appends uniform samples of the surface of `object` at the pose (about `density` per square
// metre of world area) with their albedo. Planes are not sampled here.
void sample_surface(const World& world, const Posed& posed, int object, double density, Rng& rng,
                    io::PointCloud& points);

}  // namespace retimegs::synth::synth
