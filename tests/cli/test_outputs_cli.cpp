// What the commands do with an output that already exists: every command that writes refuses it
// in one error line naming the path, unless --force, which replaces it.
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/model/model_file.hpp"
#include "retimegs/model/sh.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;

// A 3-frame, one-camera scene of mid-grey images and a model of one white Gaussian in its view.
struct Fixture {
  io::Scene scene;
  explicit Fixture(const fs::path& root) {
    scene.root = root / "scene";
    scene.num_frames = 3;
    scene.fps = 24;
    const Camera cam = test::small_camera("cam00", {0, 0, -4.0});
    scene.cameras.push_back(cam);
    for (int k = 0; k < scene.num_frames; ++k)
      media::write_png(scene.image_path(0, k), Image(64, 48, 3, 0.5f));
    io::write_scene_json(scene);
    model::Model model;
    model.grid = {0.0, 2.0, 2};
    model::Primitives& p = model.primitives;
    p.resize(1);
    const Eigen::Vector3d mean = cam.cam_to_world({0, 0, 4.0});
    for (int a = 0; a < 3; ++a) p.mu[a] = float(mean[a]), p.log_scale[a] = std::log(0.5f);
    p.q0[0] = 1;
    for (int k = 0; k < 3; ++k) p.sh[k] = float(0.5 / model::kShC0);
    p.opacity_logit[0] = 2.0f;
    p.mu_tau[0] = 1.0f;
    p.tau_l[0] = p.tau_r[0] = 2.0f;
    model::write_model(root / "model.rgs", model);
  }
};

TEST(OutputsCli, EveryCommandThatWritesRefusesAnExistingOutputUnlessForced) {
  test::TempDir dir;
  const Fixture f(dir.path());
  const std::string scene = " --scene " + f.scene.root.string();
  const std::string model = " --model " + (dir / "model.rgs").string();
  struct Case {
    std::string command;
    fs::path output;
  };
  const std::vector<Case> cases = {
      {"render" + model + scene + " --camera cam00 --time 1 --out " + (dir / "r.png").string(),
       dir / "r.png"},
      {"render" + model + scene + " --camera cam00 --times 0:2:1 --out " +
           (dir / "frames").string(),
       dir / "frames"},
      {"export" + model + " --time 1 --out " + (dir / "e.ply").string(), dir / "e.ply"},
      {"eval" + model + scene + " --frames 1 --out " + (dir / "m.json").string(), dir / "m.json"},
      {"eval" + model + scene + " --frames 1 --save-renders " + (dir / "renders").string() +
           " --out " + (dir / "m2.json").string(),
       dir / "renders"},
      {"sheet" + scene + " --out " + (dir / "sheet.png").string(), dir / "sheet.png"},
  };
  for (const Case& c : cases) {
    const auto first = test::run_cli(c.command);
    ASSERT_EQ(first.status, 0) << c.command << "\n" << first.err;
    ASSERT_TRUE(fs::exists(c.output)) << c.command;
    // The second eval with --save-renders finds its metrics file first: start it without one.
    fs::remove(dir / "m2.json");
    const auto again = test::run_cli(c.command);
    EXPECT_EQ(again.status, 2) << c.command;
    EXPECT_NE(again.err.find(c.output.string() + ": output already exists (pass --force"),
              std::string::npos)
        << again.err;
    EXPECT_TRUE(test::is_one_error_line(again.err)) << again.err;
    const auto forced = test::run_cli(c.command + " --force");
    EXPECT_EQ(forced.status, 0) << c.command << "\n" << forced.err;
  }
  // No temporary was left beside the outputs.
  for (const auto& e : fs::directory_iterator(dir.path()))
    EXPECT_NE(e.path().filename().string().front(), '.') << e.path();
}

}  // namespace
}  // namespace retimegs
