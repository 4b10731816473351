#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "retimegs/core/psnr.hpp"
#include "retimegs/eval/flow_interpolate.hpp"
#include "retimegs/eval/protocol.hpp"
#include "retimegs/io/flow_io.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"
#include "test_util.hpp"

namespace retimegs::eval {
namespace {

// A smooth texture without repeats at this size, in [0.1, 0.9], shifted by (sx, sy) pixels.
float texture(double x, double y) {
  return float(0.5 + 0.2 * std::sin(0.37 * x + 0.11 * y) * std::cos(0.23 * y - 0.05 * x) +
               0.2 * std::sin(0.071 * x * x / 40 + 0.19 * y));
}

Image shifted_texture(int w, int h, double sx, double sy) {
  Image image(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) image.at(y, x, c) = texture(x + 0.5 - sx + 7 * c, y + 0.5 - sy);
  return image;
}

Image crossfade(const Image& a, const Image& b, double alpha) {
  Image out = a;
  for (std::size_t i = 0; i < out.data.size(); ++i)
    out.data[i] = float((1 - alpha) * a.data[i] + alpha * b.data[i]);
  return out;
}

// The central part of an image (what enters or leaves the view through the border is unknown to
// any interpolation).
Image interior(const Image& image, int margin) {
  Image out(image.width - 2 * margin, image.height - 2 * margin, image.channels);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x)
      for (int c = 0; c < image.channels; ++c)
        out.at(y, x, c) = image.at(y + margin, x + margin, c);
  return out;
}

TEST(FlowInterpolate, KnownTranslationWithEstimatedFlow) {
  const int w = 96, h = 64;
  const Image a = shifted_texture(w, h, 0, 0), b = shifted_texture(w, h, 6, 2);
  const prepare::FlowPair flows = prepare::estimate_flow_pair(a, b);
  for (double alpha : {0.25, 0.5}) {
    const Image truth = shifted_texture(w, h, 6 * alpha, 2 * alpha);
    const double ours = psnr(interior(interpolate_flow(a, b, flows, alpha), 8), interior(truth, 8));
    const double fade = psnr(interior(crossfade(a, b, alpha), 8), interior(truth, 8));
    EXPECT_GT(ours, 35.0) << alpha;
    EXPECT_GT(ours, fade + 12.0) << alpha;
  }
}

// The Middlebury Urban middle frame (data/flow/README.md): the pixel average of its neighbours
// scores 27.33 dB against it; the flow baseline must do clearly better.
TEST(FlowInterpolate, BeatsTheAverageOnMiddleburyUrban) {
  RETIMEGS_REQUIRE_DATA("flow/middlebury-urban");
  const auto dir = test::shared_data() / "flow" / "middlebury-urban";
  const Image a = media::read_image(dir / "frame10.png"),
              b = media::read_image(dir / "frame11.png");
  const Image truth = media::read_image(dir / "frame10i11.png");
  EXPECT_NEAR(psnr(crossfade(a, b, 0.5), truth), 27.33, 0.05);
  const double ours = psnr(interpolate_flow(a, b, prepare::estimate_flow_pair(a, b), 0.5), truth);
  EXPECT_GT(ours, 32.0) << ours;  // 33.46 dB with OpenCV 4.6 DIS
}

// A textured 16x16 square moving 12 px to the right over a still textured background: at
// alpha = 1/2 it sits 6 px on, and the background it uncovers and the background it is about to
// cover must come from the one frame that shows them.
struct Occlusion {
  static constexpr int kW = 64, kH = 32, kX0 = 10, kY0 = 8, kSide = 16, kMove = 12;
  static bool in_square(int x, int y, int shift) {
    return x >= kX0 + shift && x < kX0 + shift + kSide && y >= kY0 && y < kY0 + kSide;
  }
  static Image frame(int shift) {
    Image image = shifted_texture(kW, kH, 0, 0);
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x)
        if (in_square(x, y, shift))
          for (int c = 0; c < 3; ++c)
            image.at(y, x, c) = 1.0f - 0.5f * texture(3 * (x - shift) + 11.0 * c, 3.0 * y);
    return image;
  }
  // Exact flow of frame `shift` towards the frame moved by `move`.
  static Flow flow(int shift, int move) {
    Flow f(kW, kH);
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x)
        if (in_square(x, y, shift)) f.uv[2 * (std::size_t(y) * kW + x)] = float(move);
    return f;
  }
};

TEST(FlowInterpolate, OcclusionsComeFromTheFrameThatSeesThem) {
  const Image a = Occlusion::frame(0), b = Occlusion::frame(Occlusion::kMove);
  const Flow forward = Occlusion::flow(0, Occlusion::kMove);
  const Flow backward = Occlusion::flow(Occlusion::kMove, -Occlusion::kMove);
  prepare::FlowPair flows{forward, backward};
  prepare::mark_inconsistent(flows.forward, backward);
  prepare::mark_inconsistent(flows.backward, forward);
  const Image truth = Occlusion::frame(Occlusion::kMove / 2);
  const Image ours = interpolate_flow(a, b, flows, 0.5);
  float worst = 0;
  for (std::size_t i = 0; i < ours.data.size(); ++i)
    worst = std::max(worst, std::abs(ours.data[i] - truth.data[i]));
  EXPECT_LT(worst, 1e-5f);
  EXPECT_LT(psnr(crossfade(a, b, 0.5), truth), 25.0);
}

TEST(FlowInterpolate, EndsReturnTheFramesAndSizesAreChecked) {
  const Image a = Occlusion::frame(0), b = Occlusion::frame(Occlusion::kMove);
  const prepare::FlowPair flows{Occlusion::flow(0, Occlusion::kMove),
                                Occlusion::flow(Occlusion::kMove, -Occlusion::kMove)};
  EXPECT_EQ(interpolate_flow(a, b, flows, 0.0).data, a.data);
  EXPECT_EQ(interpolate_flow(a, b, flows, 1.0).data, b.data);
  EXPECT_THROW(interpolate_flow(a, b, flows, 1.5), Error);
  const prepare::FlowPair small{Flow(8, 8), Flow(8, 8)};
  EXPECT_THROW(interpolate_flow(a, b, small, 0.5), Error);
}

// The baseline through a scene: frames 0 and 2 train, frame 1 is held out; the flow files of the
// pair are used when present.
TEST(FlowInterpolate, BaselineUsesTheScenesFlowFiles) {
  test::TempDir dir;
  io::Scene scene;
  scene.root = dir / "s";
  scene.num_frames = 3;
  scene.fps = 10;
  Camera cam;
  cam.name = "c0";
  cam.width = Occlusion::kW, cam.height = Occlusion::kH;
  cam.fx = cam.fy = 40, cam.cx = Occlusion::kW / 2.0, cam.cy = Occlusion::kH / 2.0;
  scene.cameras.push_back(cam);
  for (int k = 0; k < 3; ++k)
    media::write_png(scene.image_path(0, k), Occlusion::frame(k * Occlusion::kMove / 2));
  io::write_flo(scene.flow_path(0, 0, 2), Occlusion::flow(0, Occlusion::kMove));
  io::write_flo(scene.flow_path(0, 2, 0), Occlusion::flow(Occlusion::kMove, -Occlusion::kMove));
  io::write_scene_json(scene);
  scene = media::read_scene(scene.root);

  const FrameRenderer flow = baseline_renderer(scene, {0, 2}, Baseline::kFlow);
  const FrameRenderer fade = baseline_renderer(scene, {0, 2}, Baseline::kCrossfade);
  const Image truth = media::load_image(scene, 0, 1);
  // 8-bit rounding of the frames is all that is left.
  EXPECT_GT(psnr(flow(0, 1.0), truth), 50.0);
  EXPECT_LT(psnr(fade(0, 1.0), truth), 25.0);
  EXPECT_EQ(flow(0, 2.0).data, media::load_image(scene, 0, 2).data);
  EXPECT_EQ(flow(0, 5.0).data, media::load_image(scene, 0, 2).data);  // past the end: last frame
  EXPECT_EQ(parse_baseline("flow", "--baseline"), Baseline::kFlow);
  EXPECT_THROW(parse_baseline("warp", "--baseline"), Error);
}

}  // namespace
}  // namespace retimegs::eval
