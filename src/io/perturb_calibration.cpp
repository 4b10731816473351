#include "retimegs/io/perturb_calibration.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <numbers>

#include <Eigen/Geometry>

#include "retimegs/core/error.hpp"
#include "retimegs/core/fnv1a.hpp"
#include "retimegs/core/splitmix64.hpp"
#include "retimegs/io/rig_file.hpp"
#include "retimegs/io/training_views.hpp"

namespace retimegs::io {

namespace {

// One camera's draws: splitmix64's generator seeded by the seed and the camera's name.
class Draws {
 public:
  Draws(std::uint64_t seed, const std::string& name)
      : state_(splitmix64(seed) ^ fnv1a64(name.data(), name.size())) {}
  double uniform() {  // [0, 1), 53 bits
    const std::uint64_t bits = splitmix64(state_);
    state_ += 0x9e3779b97f4a7c15ULL;
    return double(bits >> 11) * 0x1.0p-53;
  }
  double factor() { return kLeastFactor + (1 - kLeastFactor) * uniform(); }
  Eigen::Vector3d direction() {  // uniform on the unit sphere
    const double z = 2 * uniform() - 1, phi = 2 * std::numbers::pi * uniform();
    const double r = std::sqrt(std::max(0.0, 1 - z * z));
    return {r * std::cos(phi), r * std::sin(phi), z};
  }

 private:
  std::uint64_t state_;
};

}  // namespace

void check_calibration_perturbation(const CalibrationPerturbation& a, const std::string& where) {
  const auto check = [&](double value, const char* what, double hi, bool open) {
    if (!std::isfinite(value) || value < 0 || value > hi || (open && value == hi))
      fail("{}: the {} must lie in [0, {}{}, got {}", where, what, hi, open ? ")" : "]", value);
  };
  check(a.rotation_degrees, "rotation (degrees)", 90, false);
  check(a.translation, "translation (a fraction of the scene extent)", 1, false);
  check(a.focal, "focal length change (a fraction)", 0.5, true);
}

CalibrationPerturbation parse_calibration_perturbation(const std::string& text,
                                                       const std::string& flag) {
  double values[3] = {};
  std::size_t at = 0;
  for (int i = 0; i < 3; ++i) {
    const std::size_t comma = i < 2 ? text.find(',', at) : text.size();
    const char *begin = text.data() + at, *end = text.data() + std::min(comma, text.size());
    const auto [ptr, ec] = std::from_chars(begin, end, values[i]);
    if (comma == std::string::npos || begin == end || ec != std::errc() || ptr != end)
      fail(
          "{}: expected ROT_DEG,TRANS_FRAC,FOCAL_FRAC (degrees, fractions of the scene extent and "
          "of the focal length, e.g. 1,0.02,0.02), got '{}'",
          flag, text);
    at = comma + 1;
  }
  const CalibrationPerturbation amount{values[0], values[1], values[2]};
  check_calibration_perturbation(amount, flag);
  return amount;
}

Scene perturb_calibration(const Scene& scene, const CalibrationPerturbation& amount,
                          std::uint64_t seed) {
  check_calibration_perturbation(amount, scene.json_path().string());
  Scene out = scene;
  out.calibration = CalibrationSource::kUser;
  const double extent = scene_extent(scene);
  for (Camera& cam : out.cameras) {
    if (cam.split != Split::kTrain) continue;
    // Every draw is made whatever the amounts, so that each stays the same when another is 0.
    Draws draw(seed, cam.name);
    const Eigen::Vector3d axis = draw.direction();
    const double angle = amount.rotation_degrees * draw.factor() * std::numbers::pi / 180;
    const Eigen::Vector3d move = draw.direction() * (amount.translation * draw.factor() * extent);
    const double sign = draw.uniform() < 0.5 ? -1 : 1;
    const double focal = 1 + sign * amount.focal * draw.factor();

    const Eigen::Matrix3d r = Eigen::AngleAxisd(angle, axis).toRotationMatrix() * cam.rotation();
    const Eigen::Vector3d centre = cam.center() + move;
    cam.world_to_camera.topLeftCorner<3, 3>() = r;
    cam.world_to_camera.topRightCorner<3, 1>() = -r * centre;
    cam.fx *= focal;
    cam.fy *= focal;
  }
  return out;
}

Scene write_perturbed_scene(const Scene& truth, const CalibrationPerturbation& amount,
                            std::uint64_t seed) {
  Scene perturbed = perturb_calibration(truth, amount, seed);
  write_rig_file(truth.root / kTrueCalibrationFile, truth.cameras);
  write_scene_json(perturbed);
  return perturbed;
}

Scene with_calibration(const Scene& scene, const std::vector<Camera>& cameras,
                       const std::string& source) {
  Scene out = scene;
  for (Camera& cam : out.cameras) {
    const auto it = std::find_if(cameras.begin(), cameras.end(),
                                 [&](const Camera& c) { return c.name == cam.name; });
    if (it == cameras.end())
      fail("{}: no camera '{}' (a camera of {})", source, cam.name, scene.json_path().string());
    if (it->width != cam.width || it->height != cam.height)
      fail("{}: camera '{}' is {}x{} but {}x{} in {}", source, cam.name, it->width, it->height,
           cam.width, cam.height, scene.json_path().string());
    cam.fx = it->fx, cam.fy = it->fy, cam.cx = it->cx, cam.cy = it->cy;
    cam.world_to_camera = it->world_to_camera;
  }
  return out;
}

CalibrationErrors calibration_errors(const Scene& truth, const std::vector<Camera>& estimated) {
  const std::string file = truth.json_path().string();
  const std::vector<int> train = training_cameras(truth);
  if (train.size() < 3)
    fail("{}: {} training camera{}: the similarity between two calibrations needs three or more",
         file, train.size(), train.size() == 1 ? "" : "s");
  std::vector<const Camera*> matched;
  std::vector<Eigen::Vector3d> from, to;
  for (const int c : train) {
    const Camera& t = truth.cameras[std::size_t(c)];
    const auto it = std::find_if(estimated.begin(), estimated.end(),
                                 [&](const Camera& e) { return e.name == t.name; });
    if (it == estimated.end()) fail("{}: training camera '{}' has no estimate", file, t.name);
    matched.push_back(&*it);
    from.push_back(it->center());
    to.push_back(t.center());
  }
  CalibrationErrors errors;
  try {
    errors.alignment = fit_similarity(from, to);
  } catch (const Error& e) {
    fail("{}: the estimated training cameras: {}", file, e.what());
  }
  const double extent = scene_extent(truth);
  for (std::size_t i = 0; i < train.size(); ++i) {
    const Camera& t = truth.cameras[std::size_t(train[i])];
    const Camera aligned = transformed(*matched[i], errors.alignment);
    CameraError e;
    e.name = t.name;
    e.rotation_degrees = rotation_angle_degrees(aligned, t);
    e.centre = (aligned.center() - t.center()).norm() / extent;
    e.focal = 0.5 * (aligned.fx / t.fx + aligned.fy / t.fy) - 1;
    errors.mean_rotation_degrees += e.rotation_degrees;
    errors.mean_centre += e.centre;
    errors.mean_focal += std::abs(e.focal);
    errors.cameras.push_back(std::move(e));
  }
  const double n = double(train.size());
  errors.mean_rotation_degrees /= n;
  errors.mean_centre /= n;
  errors.mean_focal /= n;
  return errors;
}

}  // namespace retimegs::io
