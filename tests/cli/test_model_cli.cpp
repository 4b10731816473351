// `retimegs render` / `retimegs export` on a 4D model (.rgs): any time, slow motion, speed ramps,
// bullet time, video output, and the exported Inria .ply re-rendering to the same image.
#include <cmath>
#include <filesystem>
#include <random>

#include <nlohmann/json.hpp>

#include <gtest/gtest.h>
#include <opencv2/videoio.hpp>

#include "moving_model_scene.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/io/ply.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/io/splat_ply.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/model/export.hpp"
#include "retimegs/model/model_file.hpp"
#include "retimegs/playback/render_model.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;

using Fixture = test::MovingModelScene;

std::string run(const std::string& args) {
  const auto r = test::run_cli(args);
  EXPECT_EQ(r.status, 0) << args << "\n" << r.err;
  return r.err;
}

double mean_abs_diff(const Image& a, const Image& b) {
  double sum = 0;
  for (std::size_t i = 0; i < a.data.size(); ++i) sum += std::abs(a.data[i] - b.data[i]);
  return sum / double(a.data.size());
}

TEST(ModelCli, ExportedPlyReRendersToTheSameImage) {
  test::TempDir dir;
  const Fixture f(dir.path());
  const std::string model = (dir / "model.rgs").string();
  for (double t : {3.0, 4.5}) {
    const std::string ply = (dir / ("t" + std::to_string(int(t * 10)) + ".ply")).string();
    run("export --model " + model + " --time " + std::to_string(t) + " --out " + ply);
    // Exact Inria property list.
    const auto table = io::read_ply(ply);
    ASSERT_EQ(table.names.size(), 62u);
    EXPECT_EQ(table.names.front(), "x");
    EXPECT_EQ(table.names[6], "f_dc_0");
    EXPECT_EQ(table.names[9], "f_rest_0");
    EXPECT_EQ(table.names[54], "opacity");
    EXPECT_EQ(table.names.back(), "rot_3");
    // Only the primitives alive at t (about a quarter of them) are exported.
    EXPECT_GT(table.count, 30u);
    EXPECT_LT(table.count, 120u);
    const float background[3] = {0.1f, 0.2f, 0.3f};
    for (const Camera& cam : f.scene.cameras) {
      const Image from_ply = playback::render_splats(io::read_splat_ply(ply), cam, background);
      const Image from_rgs = playback::render_model(f.model, cam, t, background);
      double max_diff = 0;
      for (std::size_t i = 0; i < from_ply.data.size(); ++i)
        max_diff = std::max(max_diff, double(std::abs(from_ply.data[i] - from_rgs.data[i])));
      EXPECT_LT(max_diff, 1e-4) << "t " << t << " camera " << cam.name;
      EXPECT_GT(mean_abs_diff(from_rgs, Image(cam.width, cam.height, 3, 0.2f)), 0.05) << "blank";
    }
  }
  // A sequence: DIR/00000.ply ... and times.csv.
  run("export --model " + model + " --times 0:1:0.5 --out " + (dir / "seq").string());
  EXPECT_TRUE(fs::exists(dir / "seq" / "00002.ply"));
  EXPECT_EQ(test::read_text(dir / "seq" / "times.csv"), "frame,time\n0,0\n1,0.5\n2,1\n");
}

TEST(ModelCli, SlowMotionRampsBulletTimeAndVideo) {
  test::TempDir dir;
  const Fixture f(dir.path());
  const std::string base =
      "render --model " + (dir / "model.rgs").string() + " --scene " + f.scene.root.string();
  // One in-between time to a PNG equals the library render.
  run(base + " --camera cam01 --time 2.5 --out " + (dir / "one.png").string());
  const float black[3] = {0, 0, 0};
  const Image lib = playback::render_model(f.model, f.scene.cameras[1], 2.5, black);
  EXPECT_LT(mean_abs_diff(media::read_image(dir / "one.png"), lib), 1.0 / 255);
  // 4x slow motion over 9 frames: 8 * 4 + 1 frames; consecutive frames differ (motion).
  run(base + " --camera cam00 --slowmo 4 --out " + (dir / "slow").string());
  int count = 0;
  for (const auto& e : fs::directory_iterator(dir / "slow"))
    count += e.path().extension() == ".png";
  EXPECT_EQ(count, 33);
  EXPECT_GT(mean_abs_diff(media::read_image(dir / "slow" / "00005.png"),
                          media::read_image(dir / "slow" / "00006.png")),
            1e-3);
  // Frame 10 of the 4x slow motion is t = 2.5 from cam00.
  EXPECT_LT(mean_abs_diff(media::read_image(dir / "slow" / "00010.png"),
                          playback::render_model(f.model, f.scene.cameras[0], 2.5, black)),
            1.0 / 255);
  // A speed ramp: keyframes (0, 0), (4, 1), (6, 5) -> times 0, .25, .5, .75, 1, 3, 5.
  test::write_text(dir / "ramp.csv", "output_frame,t\n0,0\n4,1\n6,5\n");
  run(base + " --camera cam00 --retime " + (dir / "ramp.csv").string() + " --out " +
      (dir / "ramp").string());
  EXPECT_TRUE(fs::exists(dir / "ramp" / "00006.png"));
  EXPECT_FALSE(fs::exists(dir / "ramp" / "00007.png"));
  EXPECT_LT(mean_abs_diff(media::read_image(dir / "ramp" / "00005.png"),
                          playback::render_model(f.model, f.scene.cameras[0], 3.0, black)),
            1.0 / 255);
  // Bullet time: fixed time, the camera moves from cam00 to cam01.
  run(base + " --path cam00,cam01 --time 3 --path-frames 5 --out " + (dir / "bullet").string());
  EXPECT_LT(mean_abs_diff(media::read_image(dir / "bullet" / "00004.png"),
                          playback::render_model(f.model, f.scene.cameras[1], 3.0, black)),
            1.0 / 255);
  EXPECT_GT(mean_abs_diff(media::read_image(dir / "bullet" / "00000.png"),
                          media::read_image(dir / "bullet" / "00004.png")),
            1e-3);
  // Video at the scene's fps.
  run(base + " --camera cam00 --times 0:8:0.5 --out " + (dir / "clip.mp4").string());
  cv::VideoCapture video((dir / "clip.mp4").string());
  ASSERT_TRUE(video.isOpened());
  EXPECT_EQ(int(video.get(cv::CAP_PROP_FRAME_COUNT)), 17);
  EXPECT_NEAR(video.get(cv::CAP_PROP_FPS), 24.0, 1e-3);
}

TEST(ModelCli, BadInputExitsTwoWithoutOutput) {
  test::TempDir dir;
  const Fixture f(dir.path());
  const std::string bytes = test::read_text(dir / "model.rgs");
  test::write_text(dir / "cut.rgs", bytes.substr(0, bytes.size() - 50));
  test::write_text(dir / "ramp.csv", "0,0\n3,abc\n");
  test::write_text(dir / "unordered.csv", "0,0\n4,1\n2,3\n");
  test::write_text(dir / "beyond.csv", "0,0\n4,20\n");
  const std::string scene = " --scene " + f.scene.root.string();
  const std::string model = " --model " + (dir / "model.rgs").string();
  struct Case {
    std::string args, fragment;
  };
  for (const Case& c : {
           Case{"render --model " + (dir / "cut.rgs").string() + scene +
                    " --camera cam00 --time 1 --out " + (dir / "o.png").string(),
                "cut.rgs"},
           Case{"render" + model + scene + " --camera cam00 --slowmo 2 --out " +
                    (dir / "o.png").string(),
                ".png output holds one frame"},
           Case{"render" + model + scene + " --camera camXX --time 1 --out " +
                    (dir / "o.png").string(),
                "camXX"},
           Case{"render" + model + scene + " --camera cam00 --retime " +
                    (dir / "ramp.csv").string() + " --out " + (dir / "o").string(),
                "ramp.csv:2"},
           Case{"render" + model + scene + " --camera cam00 --times 3:1:1 --out " +
                    (dir / "o").string(),
                "--times"},
           // Absurd frame counts are refused before anything is allocated.
           Case{"render" + model + scene + " --camera cam00 --slowmo 1000000000 --out " +
                    (dir / "o").string(),
                "--slowmo: 8000000001 frames; at most 1000000 frames"},
           Case{"render" + model + scene + " --path cam00,cam01 --time 3 --path-frames " +
                    "1000000000 --out " + (dir / "o").string(),
                "--path-frames: 1000000000 frames"},
           Case{"render" + model + scene + " --camera cam00 --times 0:8:0.000001 --out " +
                    (dir / "o").string(),
                "--times: 8000001 frames"},
           Case{"export --model " + (dir / "cut.rgs").string() + " --time 1 --out " +
                    (dir / "o.ply").string(),
                "cut.rgs"},
           // The model's time range is [0, 8]: beyond it the trajectories fly apart.
           Case{"render" + model + scene + " --camera cam00 --time 40 --out " +
                    (dir / "o.png").string(),
                "time 40 is outside the model's time range [0, 8]"},
           Case{"render" + model + scene + " --camera cam00 --time -3 --out " +
                    (dir / "o.png").string(),
                "time -3 is outside"},
           Case{"render" + model + scene + " --camera cam00 --times 6:9:1 --out " +
                    (dir / "o").string(),
                "time 9 is outside"},
           Case{"render" + model + scene + " --camera cam00 --retime " +
                    (dir / "beyond.csv").string() + " --out " + (dir / "o").string(),
                "is outside the model's time range"},
           Case{"render" + model + scene + " --camera cam00 --retime " +
                    (dir / "unordered.csv").string() + " --out " + (dir / "o").string(),
                "unordered.csv:3: output frame 2 after 4"},
           Case{"export" + model + " --time 8.5 --out " + (dir / "o.ply").string(),
                "time 8.5 is outside"},
           Case{"export" + model + " --times 0:12:4 --out " + (dir / "o").string(),
                "time 12 is outside"},
           // An extension that is neither an image nor a video is an error, not a folder.
           Case{"render" + model + scene + " --camera cam00 --time 1 --out " +
                    (dir / "o.jpg").string(),
                "unknown output type '.jpg'"},
       }) {
    const auto r = test::run_cli(c.args);
    EXPECT_EQ(r.status, 2) << c.args;
    EXPECT_NE(r.err.find(c.fragment), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
  for (const char* name : {"o.png", "o", "o.ply", "o.jpg"})
    EXPECT_FALSE(fs::exists(dir / name)) << name;
}

// An output named with a trailing '/' is that folder, for every command that writes folders (the
// README's own examples); it failed after all the work with "Directory not empty". A name ending
// in '/' is a folder even with a dot in it.
TEST(ModelCli, FolderOutputsWithATrailingSlash) {
  test::TempDir dir;
  const Fixture f(dir.path());
  const std::string model = " --model " + (dir / "model.rgs").string();
  const std::string render = "render" + model + " --scene " + f.scene.root.string();
  run(render + " --camera cam00 --times 1.5:2.5:0.5 --out " + (dir / "frames").string() + "/");
  for (const char* name : {"00000.png", "00001.png", "00002.png"})
    EXPECT_TRUE(fs::exists(dir / "frames" / name)) << name;
  run(render + " --camera cam00 --time 1 --out " + (dir / "take.v2").string() + "/");
  EXPECT_TRUE(fs::exists(dir / "take.v2" / "00000.png"));
  run("export" + model + " --times 0:2:1 --out " + (dir / "sequence").string() + "/");
  EXPECT_TRUE(fs::exists(dir / "sequence" / "00002.ply"));
  EXPECT_TRUE(fs::exists(dir / "sequence" / "times.csv"));
  // The 4x slow motion covers the model's range, [0, 8].
  run(render + " --camera cam00 --slowmo 4 --out " + (dir / "slow").string() + "/");
  EXPECT_TRUE(fs::exists(dir / "slow" / "00032.png"));
  EXPECT_FALSE(fs::exists(dir / "slow" / "00033.png"));
  std::size_t entries = 0;
  for (const auto& e : fs::directory_iterator(dir.path()))
    entries += !e.path().filename().string().starts_with(".");
  EXPECT_EQ(entries, 6u) << "scene, model.rgs and the four outputs, no temporary left";
}

// `eval --stability` of a merged model reports the change at its seams apart, from the seams the
// model file records.
TEST(ModelCli, EvalStabilityReportsAMergedModelsSeams) {
  test::TempDir dir;
  Fixture f(dir.path());
  for (int c = 0; c < int(f.scene.cameras.size()); ++c)
    for (int k = 0; k < f.scene.num_frames; ++k) {
      const Camera& cam = f.scene.cameras[c];
      media::write_png(f.scene.image_path(c, k), Image(cam.width, cam.height, 3, 0.5f));
    }
  f.model.config.seams = {2};  // training time 4
  model::write_model(f.model_path, f.model);
  const fs::path out = dir / "metrics.json";
  run("eval --model " + f.model_path.string() + " --scene " + f.scene.root.string() +
      " --frames 1,3 --stability --out " + out.string());
  const auto j = nlohmann::json::parse(test::read_text(out))["stability"];
  EXPECT_EQ(j["seams"], nlohmann::json::array({4.0}));
  ASSERT_TRUE(j["max_at_seams"].is_number()) << j.dump();
  ASSERT_TRUE(j["max_at_training_frames"].is_number()) << j.dump();
  EXPECT_GT(j["max_at_seams"].get<double>(), 0.0);
}

// eval prints a training camera's held-out frames and a test camera on rows of their own; a
// baseline scores the training cameras by default and refuses a test camera.
TEST(ModelCli, EvalScoresTrainingAndTestCamerasApart) {
  test::TempDir dir;
  Fixture f(dir.path());
  f.scene.cameras[1].split = Split::kTest;
  io::write_scene_json(f.scene);
  for (int c = 0; c < int(f.scene.cameras.size()); ++c)
    for (int k = 0; k < f.scene.num_frames; ++k) {
      const Camera& cam = f.scene.cameras[c];
      media::write_png(f.scene.image_path(c, k), Image(cam.width, cam.height, 3, 0.5f));
    }
  const std::string scene = " --scene " + f.scene.root.string();
  const fs::path out = dir / "metrics.json";
  const auto logged =
      test::run_cli("eval --model " + f.model_path.string() + scene + " --out " + out.string());
  ASSERT_EQ(logged.status, 0) << logged.err;
  const std::string log = logged.out + logged.err;  // the log goes to stdout
  EXPECT_NE(log.find("training cameras, held-out frames"), std::string::npos) << log;
  EXPECT_NE(log.find("test cameras (novel views)"), std::string::npos) << log;
  const auto j = nlohmann::json::parse(test::read_text(out));
  EXPECT_EQ(j["train_views"]["views"], 4);
  EXPECT_EQ(j["test_views"]["views"], 4);

  const fs::path flow = dir / "flow.json";
  run("eval --baseline crossfade" + scene + " --out " + flow.string());
  const auto b = nlohmann::json::parse(test::read_text(flow));
  EXPECT_EQ(b["train_views"]["views"], 4);
  EXPECT_TRUE(b["test_views"].is_null());
  const auto r = test::run_cli("eval --baseline crossfade" + scene + " --cameras cam01 --out " +
                               (dir / "x.json").string());
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("cam01 is a test camera"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "x.json"));
}

}  // namespace
}  // namespace retimegs
