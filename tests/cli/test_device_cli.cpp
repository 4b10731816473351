// `retimegs render --device` and `retimegs eval --device`: auto (the default) and cpu on a machine
// without a usable GPU write the same files, byte for byte; cuda there fails with status 2 and one
// line naming the reason and --device cpu. (GPU against CPU images: tests/playback_cuda.)
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli/moving_model_scene.hpp"
#include "retimegs/cuda/device.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;

// MovingModelScene with mid-grey images, for eval's ground truth.
struct Fixture : test::MovingModelScene {
  explicit Fixture(const fs::path& root) : MovingModelScene(root) {
    for (int c = 0; c < int(scene.cameras.size()); ++c)
      for (int k = 0; k < scene.num_frames; ++k) {
        fs::create_directories(scene.image_path(c, k).parent_path());
        const Camera& cam = scene.cameras[c];
        cv::imwrite(scene.image_path(c, k).string(),
                    cv::Mat(cam.height, cam.width, CV_8UC3, cv::Scalar(128, 128, 128)));
      }
  }
  std::string render(const std::string& args) const {
    return "render --model " + model_path.string() + " --scene " + scene.root.string() +
           " --camera cam01 --time 3.5 " + args;
  }
  std::string eval(const std::string& args) const {
    return "eval --model " + model_path.string() + " --scene " + scene.root.string() +
           " --frames 1,3 --stability " + args;
  }
};

bool gpu_usable() {
  return cuda::query_device().usable();
}

// A user with a GPU computes on it unless they say otherwise.
TEST(DeviceCli, AutoIsTheDefault) {
  for (const char* command : {"train", "render", "eval"}) {
    const auto r = test::run_cli(std::string(command) + " --help");
    EXPECT_NE(r.out.find("--device TEXT=auto"), std::string::npos) << command << "\n" << r.out;
  }
}

TEST(DeviceCli, CpuAndAutoWithoutAGpuWriteTheSameFiles) {
  if (gpu_usable()) GTEST_SKIP() << "a GPU is present: auto runs on it (tests/playback_cuda)";
  test::TempDir dir;
  const Fixture f(dir.path());
  for (const std::string device : {"", " --device cpu", " --device auto"}) {
    const std::string tag = device.empty() ? "default" : device.substr(10);
    for (const std::string& command :
         {f.render("--out " + (dir / (tag + ".png")).string() + device),
          f.render("--alpha --out " + (dir / (tag + "_rgba.png")).string() + device),
          f.eval("--out " + (dir / (tag + ".json")).string() + device)}) {
      const auto r = test::run_cli(command);
      ASSERT_EQ(r.status, 0) << command << "\n" << r.err;
    }
  }
  for (const std::string file : {".png", "_rgba.png", ".json"}) {
    const std::string by_default = test::read_text(dir / ("default" + file));
    ASSERT_FALSE(by_default.empty()) << file;
    EXPECT_EQ(test::read_text(dir / ("cpu" + file)), by_default) << file;
    EXPECT_EQ(test::read_text(dir / ("auto" + file)), by_default) << file;
  }
}

TEST(DeviceCli, CudaWithoutAGpuFailsNamingTheReasonAndCpu) {
  const cuda::DeviceQuery query = cuda::query_device();
  if (query.usable()) GTEST_SKIP() << "a GPU is present: " << query.device->name;
  test::TempDir dir;
  const Fixture f(dir.path());
  for (const std::string& command : {f.render("--device cuda --out " + (dir / "o.png").string()),
                                     f.eval("--device cuda --out " + (dir / "o.json").string())}) {
    const auto r = test::run_cli(command);
    EXPECT_EQ(r.status, 2) << command;
    EXPECT_TRUE(test::is_one_error_line(r.err)) << r.err;
    EXPECT_NE(r.err.find(query.reason), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("--device cpu"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "o.png"));
    EXPECT_FALSE(fs::exists(dir / "o.json"));
  }
}

TEST(DeviceCli, UnknownDeviceIsRefused) {
  test::TempDir dir;
  const Fixture f(dir.path());
  const auto r = test::run_cli(f.render("--device tpu --out " + (dir / "o.png").string()));
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(test::is_one_error_line(r.err)) << r.err;
  EXPECT_NE(r.err.find("--device 'tpu'"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace retimegs
