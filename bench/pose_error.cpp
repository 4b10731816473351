// A calibration against the true one: per training camera, the rotation error in degrees, the
// centre error in % of the scene extent and the focal length error in %, after the similarity
// (Umeyama on the camera centres, estimated onto true) that nothing in a scene fixes
// (io::calibration_errors), and their means. The truth is a rig file, calibration_true.json
// beside a scene perturbed by perturb_calibration or `retimegs synth --perturb-calibration`.
//
// Usage: pose_error --scene DIR [--truth FILE] [--model RUN/model.rgs] [--json OUT]
//   FILE: default DIR/calibration_true.json. Compares DIR/scene.json's cameras (the calibration
//   training starts from) with the truth, and with --model the cameras as the model saw them
//   (model::seen_camera: through the pose corrections training learned); OUT gets the same
//   figures as JSON.
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/ingest/rig_file.hpp"
#include "retimegs/io/perturb_calibration.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/model/model_file.hpp"

namespace fs = std::filesystem;
using namespace retimegs;
using json = nlohmann::json;

namespace {

// One comparison: a Markdown table on stdout, and its figures as JSON.
json report(const std::string& title, const io::Scene& truth,
            const std::vector<Camera>& estimated) {
  const io::CalibrationErrors errors = io::calibration_errors(truth, estimated);
  std::printf("\n%s (after a similarity of scale %.6g)\n\n", title.c_str(), errors.alignment.scale);
  std::printf("| camera | rotation (deg) | centre (%% of extent) | focal (%%) |\n");
  std::printf("|---|---|---|---|\n");
  json cameras = json::array();
  for (const io::CameraError& e : errors.cameras) {
    std::printf("| %s | %.4f | %.4f | %+.4f |\n", e.name.c_str(), e.rotation_degrees,
                100 * e.centre, 100 * e.focal);
    cameras.push_back({{"name", e.name},
                       {"rotation_degrees", e.rotation_degrees},
                       {"centre_percent", 100 * e.centre},
                       {"focal_percent", 100 * e.focal}});
  }
  std::printf("| mean | %.4f | %.4f | %.4f |\n", errors.mean_rotation_degrees,
              100 * errors.mean_centre, 100 * errors.mean_focal);
  return {{"title", title},
          {"alignment_scale", errors.alignment.scale},
          {"mean_rotation_degrees", errors.mean_rotation_degrees},
          {"mean_centre_percent", 100 * errors.mean_centre},
          {"mean_focal_percent", 100 * errors.mean_focal},
          {"cameras", cameras}};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("A scene's calibration against the true one, after a similarity.");
  std::string scene_dir, truth_file, model_file, json_out;
  app.add_option("--scene", scene_dir, "scene folder")->required();
  app.add_option("--truth", truth_file,
                 "the true calibration (default SCENE/calibration_true.json)");
  app.add_option("--model", model_file, "a model trained on the scene: its refined cameras too");
  app.add_option("--json", json_out, "also write the figures to this JSON file");
  CLI11_PARSE(app, argc, argv);
  try {
    const io::Scene scene = io::read_scene_json(scene_dir);
    const fs::path truth_path =
        truth_file.empty() ? scene.root / io::kTrueCalibrationFile : fs::path(truth_file);
    const io::Scene truth =
        io::with_calibration(scene, ingest::read_rig_cameras(truth_path), truth_path.string());
    std::printf("%s against %s: %zu training cameras, extent %.6g\n", scene.json_path().c_str(),
                truth_path.c_str(), io::training_cameras(truth).size(), io::scene_extent(truth));
    json out = json::array();
    out.push_back(report("before refinement: scene.json", truth, scene.cameras));
    if (!model_file.empty()) {
      const model::Model model = model::read_model(model_file);
      std::vector<Camera> seen;
      for (const Camera& camera : scene.cameras) seen.push_back(model::seen_camera(model, camera));
      out.push_back(report("after refinement: " + model_file, truth, seen));
    }
    if (!json_out.empty()) write_text_file(json_out, out.dump(2) + "\n");
  } catch (const Error& e) {
    std::fprintf(stderr, "pose_error: %s\n", e.what());
    return 2;
  }
  return 0;
}
