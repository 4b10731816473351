#pragma once
// Calibrations with a known error: a scene's training cameras moved by seeded amounts, so that
// camera refinement is measured against the exact answer (`synth --perturb-calibration`,
// bench/perturb_calibration), and the error of a calibration against the true one, after the
// similarity that nothing in a scene fixes.
#include <cstdint>
#include <string>
#include <vector>

#include "retimegs/core/camera.hpp"
#include "retimegs/core/similarity.hpp"
#include "retimegs/io/scene.hpp"

namespace retimegs::io {

// The true calibration beside a perturbed scene's scene.json, as a rig file (rig_file.hpp).
constexpr const char* kTrueCalibrationFile = "calibration_true.json";

// How far each training camera moves. Each amount is the given magnitude times a factor drawn
// for the camera uniformly in [kLeastFactor, 1], so that the cameras differ and none is exact.
struct CalibrationPerturbation {
  double rotation_degrees = 0;  // turned about its own centre, about a random axis
  double translation = 0;       // centre moved in a random direction, a fraction of scene_extent
  double focal = 0;             // fx and fy scaled by 1 + or - this (one factor, random sign)
};
constexpr double kLeastFactor = 0.5;

// Throws Error naming `where` unless each amount is finite, rotation_degrees in [0, 90],
// translation in [0, 1] and focal in [0, 0.5).
void check_calibration_perturbation(const CalibrationPerturbation& amount,
                                    const std::string& where);

// "ROT_DEG,TRANS_FRAC,FOCAL_FRAC" (e.g. "1,0.02,0.02"), checked; throws Error naming `flag`.
CalibrationPerturbation parse_calibration_perturbation(const std::string& text,
                                                       const std::string& flag);

// The scene with each training camera perturbed by `amount`; test cameras, image sizes and
// principal points stay exact. A camera's draws depend on `seed` and its name alone (not on the
// other cameras), so a subset of a rig is perturbed as in the whole. The result's calibration is
// kUser. Distances are fractions of scene_extent(scene).
Scene perturb_calibration(const Scene& scene, const CalibrationPerturbation& amount,
                          std::uint64_t seed);

// Writes truth's cameras (every one, as they are) to truth.root / kTrueCalibrationFile, then
// perturb_calibration(truth, amount, seed) to truth.root / scene.json, each atomically and in
// that order (a scene.json beside no true calibration is never perturbed); returns the latter.
Scene write_perturbed_scene(const Scene& truth, const CalibrationPerturbation& amount,
                            std::uint64_t seed);

// The scene with each camera's intrinsics and pose taken from the camera of the same name in
// `cameras` (e.g. calibration_true.json read back: the true scene of a perturbed one); names,
// sizes, splits and the rest kept. Throws Error naming `source` and the camera for a scene camera
// that `cameras` lacks or gives another image size.
Scene with_calibration(const Scene& scene, const std::vector<Camera>& cameras,
                       const std::string& source);

// One camera's error against the truth after the alignment.
struct CameraError {
  std::string name;
  double rotation_degrees = 0;  // angle between the aligned and the true orientation
  double centre = 0;            // aligned centre to true centre, a fraction of the true extent
  double focal = 0;             // mean of fx / fx_true - 1 and fy / fy_true - 1 (signed)
};

struct CalibrationErrors {
  std::vector<CameraError> cameras;  // the truth's training cameras, in its order
  Similarity alignment;              // estimated -> true, fitted to those cameras' centres
  double mean_rotation_degrees = 0, mean_centre = 0, mean_focal = 0;  // means of |.|
};

// The errors of `estimated` (cameras matched by name) against the training cameras of `truth`,
// after the similarity that best maps the estimated centres onto the true ones (fit_similarity):
// a calibration is only known up to one, and a refinement of every camera may drift by one.
// Extent: scene_extent(truth). Throws Error naming a training camera `estimated` lacks, or when
// fewer than three training cameras (not on one line) determine the similarity.
CalibrationErrors calibration_errors(const Scene& truth, const std::vector<Camera>& estimated);

}  // namespace retimegs::io
