// A scene's calibration made a user's: each training camera of DIR/scene.json perturbed by seeded
// amounts (io::perturb_calibration: turned about its centre by up to --rotation degrees, moved by
// up to --translation of the scene extent, focal lengths scaled by 1 +- up to --focal; each amount
// at least half its bound), the true cameras written beside it as DIR/calibration_true.json (a
// rig file). Run again on the same scene, it starts from calibration_true.json, not from the
// perturbed cameras, so another seed replaces the perturbation instead of adding to it. What
// camera refinement recovers is measured with pose_error (bench/README.md, "Calibration").
//
// Usage: perturb_calibration --scene DIR --rotation DEG --translation FRAC --focal FRAC [--seed N]
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>

#include <CLI/CLI.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/core/similarity.hpp"
#include "retimegs/ingest/rig_file.hpp"
#include "retimegs/io/perturb_calibration.hpp"
#include "retimegs/io/training_views.hpp"

namespace fs = std::filesystem;
using namespace retimegs;

int main(int argc, char** argv) {
  CLI::App app("Perturb a scene's training cameras by seeded amounts; the truth goes beside it.");
  std::string scene_dir;
  io::CalibrationPerturbation amount;
  std::uint64_t seed = 0;
  app.add_option("--scene", scene_dir, "scene folder (scene.json is rewritten)")->required();
  app.add_option("--rotation", amount.rotation_degrees, "largest turn, degrees")->required();
  app.add_option("--translation", amount.translation, "largest move, fraction of the extent")
      ->required();
  app.add_option("--focal", amount.focal, "largest focal length change, fraction")->required();
  app.add_option("--seed", seed, "seed of the draws")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    io::check_calibration_perturbation(amount, "--rotation, --translation, --focal");
    io::Scene truth = io::read_scene_json(scene_dir);
    const fs::path true_file = truth.root / io::kTrueCalibrationFile;
    const bool again = fs::exists(true_file);
    if (again)
      truth = io::with_calibration(truth, ingest::read_rig_cameras(true_file), true_file.string());
    const io::Scene perturbed = io::write_perturbed_scene(truth, amount, seed);
    const double extent = io::scene_extent(truth);
    std::printf("%s: %s; training cameras perturbed (seed %llu), the truth in %s\n",
                truth.json_path().c_str(), again ? "from the truth of an earlier run" : "as read",
                static_cast<unsigned long long>(seed), true_file.c_str());
    std::printf("| camera | rotation (deg) | centre (%% of extent %.4g) | focal (%%) |\n", extent);
    std::printf("|---|---|---|---|\n");
    for (std::size_t c = 0; c < truth.cameras.size(); ++c) {
      const Camera &t = truth.cameras[c], &p = perturbed.cameras[c];
      if (t.split != Split::kTrain) continue;
      std::printf("| %s | %.3f | %.3f | %+.3f |\n", t.name.c_str(), rotation_angle_degrees(p, t),
                  100 * (p.center() - t.center()).norm() / extent, 100 * (p.fx / t.fx - 1));
    }
  } catch (const Error& e) {
    std::fprintf(stderr, "perturb_calibration: %s\n", e.what());
    return 2;
  }
  return 0;
}
