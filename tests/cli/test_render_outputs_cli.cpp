// `retimegs render` outputs for a VFX pipeline: --size / --scale render at another size (the
// camera's intrinsics scaled, not a resampled image), --alpha writes straight RGBA PNGs,
// --bit-depth 16 16-bit PNGs, --fps the video's rate (the scene's by default), a folder gets
// times.csv, --depth a float depth pass beside each EXR frame, --crf the H.264 quality; options
// that do not fit the output are refused with one line and status 2, and so is H.264 without the
// ffmpeg program.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "cli_run.hpp"
#include "retimegs/core/executable.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/io/splat_ply.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/model/export.hpp"
#include "retimegs/model/model_file.hpp"
#include "retimegs/playback/model_renderer.hpp"
#include "retimegs/playback/render_model.hpp"
#include "retimegs/render/depth.hpp"
#include "soft_cloud.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;

// A 3-frame scene at 24 fps with one 64x48 camera, and a model of a few soft primitives around
// the origin that leave the image border empty.
struct Fixture {
  io::Scene scene;
  model::Model model;
  fs::path root;
  explicit Fixture(const fs::path& dir) : root(dir) {
    scene.root = dir / "scene";
    scene.num_frames = 3;
    scene.fps = 24;
    scene.cameras.push_back(test::small_camera("cam00", {0, 0, -4.0}));
    for (int k = 0; k < scene.num_frames; ++k)
      media::write_png(scene.image_path(0, k), Image(64, 48, 3, 0.5f));
    io::write_scene_json(scene);

    model = test::soft_cloud(
        {.count = 10, .seed = 11, .spread = 0.5f, .drift = 0.2f, .opacity_logit = {}});
    model::write_model(dir / "model.rgs", model);
  }
  // `retimegs render` of this model and scene from cam00 with the near plane the library uses.
  test::CommandResult render(const std::string& args) const {
    return test::run_cli("render --model " + (root / "model.rgs").string() + " --scene " +
                         scene.root.string() + " --camera cam00 --near 0.01 " + args);
  }
};

render::RenderOptions near_001() {
  render::RenderOptions options;
  options.near_plane = 0.01f;
  return options;
}

double max_abs_diff(const Image& a, const Image& b) {
  EXPECT_EQ(a.data.size(), b.data.size());
  double d = 0;
  for (std::size_t i = 0; i < std::min(a.data.size(), b.data.size()); ++i)
    d = std::max(
        d, double(std::abs(std::clamp(a.data[i], 0.0f, 1.0f) - std::clamp(b.data[i], 0.0f, 1.0f))));
  return d;
}

TEST(RenderOutputsCli, SizeAndScaleRenderAtTheNewSize) {
  test::TempDir dir;
  const Fixture f(dir.path());
  const std::string at = " --time 1 --out ";
  ASSERT_EQ(f.render("--size 32x24" + at + (dir / "size.png").string()).status, 0);
  ASSERT_EQ(f.render("--scale 0.5" + at + (dir / "scale.png").string()).status, 0);
  const Image size = media::read_image(dir / "size.png"),
              scale = media::read_image(dir / "scale.png");
  ASSERT_EQ(size.width, 32);
  ASSERT_EQ(size.height, 24);
  EXPECT_EQ(size.data, scale.data);
  // Rendered at 32x24 through the scaled intrinsics (8-bit rounding apart).
  const float black[3] = {0, 0, 0};
  const Image lib =
      playback::render_model(f.model, resized(f.scene.cameras[0], 32, 24), 1.0, black, near_001());
  EXPECT_LT(max_abs_diff(size, lib), 0.5 / 255 + 1e-6);
}

TEST(RenderOutputsCli, AlphaWritesStraightRgbaThatCompositesToTheRender) {
  test::TempDir dir;
  const Fixture f(dir.path());
  const std::string at = " --time 1 --background 1,1,1 --out ";
  ASSERT_EQ(f.render("--alpha" + at + (dir / "rgba.png").string()).status, 0);
  ASSERT_EQ(f.render(at + (dir / "rgb.png").string()).status, 0);
  const cv::Mat rgba = cv::imread((dir / "rgba.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(rgba.type(), CV_8UC4);
  const Image rgb = media::read_image(dir / "rgb.png");
  const Image lib =
      playback::ModelRenderer(f.model).render_rgba(f.scene.cameras[0], 1.0, near_001());
  int empty = 0, partial = 0;
  for (int y = 0; y < rgba.rows; ++y)
    for (int x = 0; x < rgba.cols; ++x) {
      const cv::Vec4b v = rgba.at<cv::Vec4b>(y, x);
      const double a = v[3] / 255.0;
      EXPECT_NEAR(a, lib.at(y, x, 3), 0.5 / 255 + 1e-6);
      empty += v[3] == 0;
      partial += v[3] > 10 && v[3] < 245;
      for (int c = 0; c < 3; ++c)  // over the white background: the render without --alpha
        EXPECT_NEAR(a * v[2 - c] / 255.0 + (1 - a), rgb.at(y, x, c), 2.5 / 255)
            << x << "," << y << "," << c;
    }
  EXPECT_GT(empty, 0);
  EXPECT_GT(partial, 20);
}

TEST(RenderOutputsCli, SixteenBitPngs) {
  test::TempDir dir;
  const Fixture f(dir.path());
  ASSERT_EQ(f.render("--bit-depth 16 --times 0:1:1 --out " + (dir / "deep/").string()).status, 0);
  const cv::Mat codes = cv::imread((dir / "deep" / "00001.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(codes.type(), CV_16UC3);
  const float black[3] = {0, 0, 0};
  const Image lib = playback::render_model(f.model, f.scene.cameras[0], 1.0, black, near_001());
  int between_8_bit_codes = 0;
  for (int y = 0; y < codes.rows; ++y)
    for (int x = 0; x < codes.cols; ++x)
      for (int c = 0; c < 3; ++c) {
        const int code = codes.at<cv::Vec<std::uint16_t, 3>>(y, x)[2 - c];
        EXPECT_NEAR(code / 65535.0, std::clamp(lib.at(y, x, c), 0.0f, 1.0f), 1e-4);
        between_8_bit_codes += code % 257 != 0;
      }
  EXPECT_GT(between_8_bit_codes, 100);
}

TEST(RenderOutputsCli, FpsSetsTheVideoRateAndTheSceneGivesTheDefault) {
  test::TempDir dir;
  const Fixture f(dir.path());
  ASSERT_EQ(f.render("--times 0:2:0.25 --fps 12.5 --out " + (dir / "a.mp4").string()).status, 0);
  ASSERT_EQ(f.render("--times 0:2:0.5 --out " + (dir / "b.mp4").string()).status, 0);
  for (const auto& [name, fps, frames] : {std::tuple{"a.mp4", 12.5, 9}, {"b.mp4", 24.0, 5}}) {
    cv::VideoCapture cap((dir / name).string(), cv::CAP_FFMPEG);
    ASSERT_TRUE(cap.isOpened()) << name;
    EXPECT_NEAR(cap.get(cv::CAP_PROP_FPS), fps, 1e-6) << name;
    const int fourcc = int(cap.get(cv::CAP_PROP_FOURCC));
    EXPECT_EQ(fourcc, cv::VideoWriter::fourcc('a', 'v', 'c', '1')) << name;
    int read = 0;
    for (cv::Mat frame; cap.read(frame);) ++read;
    EXPECT_EQ(read, frames) << name;
  }
}

// The PSNR in dB of a video's decoded frames, all together, against the PNG frames of `folder`.
double video_psnr(const fs::path& video, const fs::path& folder) {
  cv::VideoCapture cap(video.string(), cv::CAP_FFMPEG);
  EXPECT_TRUE(cap.isOpened()) << video;
  double se = 0, values = 0;
  int k = 0;
  for (cv::Mat decoded; cap.read(decoded); ++k) {
    const cv::Mat png = cv::imread((folder / fmt::format("{:05d}.png", k)).string());
    EXPECT_EQ(png.size(), decoded.size()) << video << " frame " << k;
    if (png.size() != decoded.size()) return 0;
    cv::Mat d;
    cv::absdiff(png, decoded, d);
    d.convertTo(d, CV_64F);
    se += cv::sum(d.mul(d))[0] + cv::sum(d.mul(d))[1] + cv::sum(d.mul(d))[2];
    values += 3.0 * double(d.total());
  }
  EXPECT_GT(k, 0) << video;
  return 10 * std::log10(255.0 * 255.0 / std::max(se / std::max(values, 1.0), 1e-12));
}

// --crf sets the H.264 quality: the renders of --crf 0 are larger and decode closer to the same
// frames written as PNGs than those of --crf 40; x264 signs each with its rate control.
TEST(RenderOutputsCli, CrfSetsTheH264Quality) {
  test::TempDir dir;
  const Fixture f(dir.path());
  const std::string shot = "--times 0:2:0.25 --scale 2 --out ";
  ASSERT_EQ(f.render(shot + (dir / "frames/").string()).status, 0);
  for (const char* crf : {"0", "40"}) {
    const auto r = f.render("--crf " + std::string(crf) + " " + shot +
                            (dir / (std::string("crf") + crf + ".mp4")).string());
    ASSERT_EQ(r.status, 0) << r.err;
  }
  const fs::path lossless = dir / "crf0.mp4", coarse = dir / "crf40.mp4";
  EXPECT_NE(test::read_text(lossless).find("rc=cqp"), std::string::npos);  // x264's lossless mode
  EXPECT_NE(test::read_text(coarse).find("crf=40.0"), std::string::npos);
  EXPECT_GT(fs::file_size(lossless), 2 * fs::file_size(coarse));
  const double lossless_db = video_psnr(lossless, dir / "frames"),
               coarse_db = video_psnr(coarse, dir / "frames");
  EXPECT_GT(lossless_db, coarse_db + 5) << lossless_db << " vs " << coarse_db;
}

// H.264 is written by the ffmpeg program: without it on PATH, render refuses in one line that
// says what to install, before rendering, and writes nothing.
TEST(RenderOutputsCli, H264WithoutFfmpegIsRefusedInOneLine) {
  test::TempDir dir;
  const Fixture f(dir.path());
  fs::create_directories(dir / "bin");  // `timeout` alone, which the test runs the command under
  fs::create_symlink(find_executable("timeout"), dir / "bin" / "timeout");
  const fs::path out = dir / "clip.mp4";
  const auto r = test::run_cli_timed(
      "render --model " + (dir / "model.rgs").string() + " --scene " + f.scene.root.string() +
          " --camera cam00 --times 0:2:0.5 --crf 18 --out " + out.string(),
      60, "export PATH=" + (dir / "bin").string() + "; ");
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_TRUE(test::is_single_error_line(r.err)) << r.err;
  EXPECT_NE(r.err.find(out.string() + ": H.264 video"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("install it (Debian package ffmpeg"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

TEST(RenderOutputsCli, AFolderGetsTimesCsv) {
  test::TempDir dir;
  const Fixture f(dir.path());
  ASSERT_EQ(f.render("--times 0:2:0.5 --out " + (dir / "frames/").string()).status, 0);
  EXPECT_EQ(test::read_text(dir / "frames" / "times.csv"),
            "frame,time\n0,0\n1,0.5\n2,1\n3,1.5\n4,2\n");
  EXPECT_TRUE(fs::exists(dir / "frames" / "00004.png"));
}

// The depth pass file `path`: one 32-bit float channel at the camera's size.
std::vector<float> read_depth(const fs::path& path) {
  const cv::Mat read = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(read.type(), CV_32FC1) << path;
  EXPECT_EQ(read.cols, 64) << path;
  EXPECT_EQ(read.rows, 48) << path;
  if (read.type() != CV_32FC1) return {};
  return {read.ptr<float>(), read.ptr<float>() + read.total()};
}

// --depth writes ModelRenderer's depth pass, as it is, beside each EXR frame: x.depth.exr, and
// <frame>.depth.exr in a folder; a static .ply gets the same pass. PNGs and videos cannot carry
// one: refused with one line, nothing written.
TEST(RenderOutputsCli, DepthWritesTheFloatPassBesideEachExrFrame) {
  if (!media::can_write_exr()) GTEST_SKIP() << "this OpenCV build writes no OpenEXR";
  ::setenv("OPENCV_IO_ENABLE_OPENEXR", "1", 1);  // OpenCV reads EXR only when asked to
  test::TempDir dir;
  const Fixture f(dir.path());
  const Camera& cam = f.scene.cameras[0];
  const float black[3] = {0, 0, 0};
  const auto expected = [&](const playback::ModelRenderer& renderer, double t) {
    Image depth;
    renderer.render(cam, t, black, near_001(), playback::Colors::kModel, &depth);
    return depth.data;
  };
  const playback::ModelRenderer model(f.model);
  ASSERT_EQ(f.render("--depth --time 1 --out " + (dir / "plate.exr").string()).status, 0);
  EXPECT_EQ(read_depth(dir / "plate.depth.exr"), expected(model, 1.0));
  ASSERT_EQ(
      f.render("--depth --alpha --exr float --times 0:1:0.5 --out " + (dir / "frames/").string())
          .status,
      0);
  for (int k = 0; k < 3; ++k)
    EXPECT_EQ(read_depth(dir / "frames" / ("0000" + std::to_string(k) + ".depth.exr")),
              expected(model, 0.5 * k))
        << k;
  EXPECT_TRUE(fs::exists(dir / "frames" / "00002.exr"));

  const Splats splats = model::export_splats(f.model, 1.0);
  io::write_splat_ply(dir / "splats.ply", splats);
  ASSERT_EQ(test::run_cli("render --model " + (dir / "splats.ply").string() + " --scene " +
                          f.scene.root.string() + " --camera cam00 --near 0.01 --depth --out " +
                          (dir / "static.exr").string())
                .status,
            0);
  const std::vector<float> depth = read_depth(dir / "static.depth.exr");
  EXPECT_EQ(depth, expected(playback::ModelRenderer(splats), 0));
  int empty = 0, drawn = 0;  // the cloud around the origin, 4 units away, in an empty border
  for (const float z : depth) {
    empty += z == render::kNoDepth;
    drawn += z > 3 && z < 5;
  }
  EXPECT_EQ(empty + drawn, int(depth.size()));
  EXPECT_GT(empty, 100);
  EXPECT_GT(drawn, 100);

  for (const std::string out : {"v.mp4", "v.png", "pngs/"}) {
    const auto r = f.render("--depth --times 0:1:1 --out " + (dir / out).string());
    const auto one = f.render("--depth --time 1 --out " + (dir / out).string());
    for (const auto& result : {r, one}) {
      EXPECT_EQ(result.status, 2) << out;
      EXPECT_NE(result.err.find("--depth"), std::string::npos) << out << ": " << result.err;
      EXPECT_TRUE(test::is_one_error_line(result.err)) << out << ": " << result.err;
    }
    EXPECT_FALSE(fs::exists(dir / out)) << out;
  }
  EXPECT_FALSE(fs::exists(dir / "v.depth.exr"));
}

TEST(RenderOutputsCli, OptionsThatDoNotFitExitTwoWithOneLine) {
  test::TempDir dir;
  const Fixture f(dir.path());
  const std::string mp4 = " --times 0:1:0.5 --out " + (dir / "out.mp4").string();
  const std::string png = " --time 1 --out " + (dir / "out.png").string();
  struct Case {
    std::string args, fragment;
  };
  for (const Case& c :
       {Case{"--alpha" + mp4, "--alpha"}, Case{"--bit-depth 16" + mp4, "--bit-depth"},
        Case{"--bit-depth 12" + png, "--bit-depth"}, Case{"--size 40x40" + png, "--size"},
        Case{"--size 640x480x2" + png, "--size"}, Case{"--size 32x24 --scale 0.5" + png, "--scale"},
        Case{"--scale 0" + png, "--scale"}, Case{"--scale -2" + png, "--scale"},
        Case{"--size 33x25" + mp4, "even"}, Case{"--fps 0" + mp4, "--fps"},
        Case{"--fps -3" + mp4, "--fps"}, Case{"--fps nan" + mp4, "--fps"},
        Case{"--fps inf" + mp4, "--fps"}, Case{"--crf 52" + mp4, "--crf 52"},
        Case{"--crf -1" + mp4, "--crf -1"}, Case{"--crf 18" + png, "--crf"}}) {
    const auto r = f.render(c.args);
    EXPECT_EQ(r.status, 2) << c.args;
    EXPECT_NE(r.err.find(c.fragment), std::string::npos) << c.args << ": " << r.err;
    EXPECT_TRUE(test::is_one_error_line(r.err)) << c.args << ": " << r.err;
    EXPECT_FALSE(fs::exists(dir / "out.mp4")) << c.args;
    EXPECT_FALSE(fs::exists(dir / "out.png")) << c.args;
  }
}

}  // namespace
}  // namespace retimegs
