// Background-model masks (`prepare --masks`): what moves is found, what stays is not, specks go,
// holes close, and prepare writes them for a scene without masks so that its points use the hull.
#include <cmath>
#include <filesystem>
#include <optional>
#include <random>
#include <vector>

#include "retimegs/core/error.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"
#include "retimegs/prepare/masks.hpp"
#include "retimegs/prepare/prepare.hpp"
#include "retimegs/synth/synth.hpp"
#include "test_util.hpp"

namespace retimegs::prepare {
namespace {
namespace fs = std::filesystem;

// A noisy textured grey background (a fixed camera's sensor noise differs frame to frame).
Image background(int width, int height, std::mt19937& rng) {
  std::normal_distribution<float> noise(0.0f, 0.01f);
  Image image(width, height, 3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < 3; ++c)
        image.at(y, x, c) = 0.4f + 0.2f * float(((x / 4 + y / 4) % 2)) + noise(rng);
  return image;
}

void paint(Image& image, int x0, int y0, int x1, int y1, float r, float g, float b) {
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      image.at(y, x, 0) = r;
      image.at(y, x, 1) = g;
      image.at(y, x, 2) = b;
    }
}

std::vector<std::size_t> every(std::size_t n) {
  std::vector<std::size_t> all(n);
  for (std::size_t k = 0; k < n; ++k) all[k] = k;
  return all;
}

double foreground(const Image& mask, int x0, int y0, int x1, int y1) {
  double sum = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) sum += mask.at(y, x);
  return sum / double((x1 - x0) * (y1 - y0));
}

// A 16x16 red square crosses a 96x64 frame in 12 frames, with a 4x4 hole of background colour in
// its middle; a single-pixel speck moves elsewhere.
TEST(BackgroundMasks, FindTheMovingSquareWithItsHoleFilledAndWithoutSpecks) {
  std::mt19937 rng(1);
  const int width = 96, height = 64, frames = 12;
  std::vector<Image> clip;
  std::vector<int> left;
  for (int k = 0; k < frames; ++k) {
    Image image = background(width, height, rng);
    const int x = 4 + 6 * k;
    left.push_back(x);
    paint(image, x, 20, x + 16, 36, 0.9f, 0.1f, 0.1f);
    paint(image, x + 6, 26, x + 10, 30, 0.5f, 0.5f, 0.5f);
    paint(image, 10 + k, 50, 11 + k, 51, 1.0f, 1.0f, 1.0f);  // a speck
    clip.push_back(std::move(image));
  }
  {
    const std::vector<Image> masks = background_masks(clip, every(frames), {});
    ASSERT_EQ(masks.size(), std::size_t(frames));
    for (int k = 0; k < frames; ++k) {
      const Image& m = masks[k];
      ASSERT_EQ(m.width, width);
      ASSERT_EQ(m.channels, 1);
      const int x = left[k];
      EXPECT_GT(foreground(m, x + 1, 21, x + 15, 35), 0.95) << k;
      EXPECT_EQ(foreground(m, x + 6, 26, x + 10, 30), 1.0) << "hole " << k;  // filled
      EXPECT_EQ(foreground(m, 0, 45, width, height), 0.0) << "speck " << k;  // dropped
      // Nothing far from the square.
      EXPECT_EQ(foreground(m, 0, 0, width, 12), 0.0) << k;
    }
  }
}

TEST(BackgroundMasks, AStillClipHasNoForeground) {
  std::mt19937 rng(2);
  std::vector<Image> clip;
  for (int k = 0; k < 9; ++k) clip.push_back(background(64, 48, rng));
  for (const Image& m : background_masks(clip, every(9), {}))
    EXPECT_EQ(foreground(m, 0, 0, 64, 48), 0.0);
}

// Held-out frames are classified by the model of the learnt ones: a square that appears only in
// a held-out frame is found there, and the learnt frames know nothing of it.
TEST(BackgroundMasks, LearnsFromTheListedFramesOnly) {
  std::mt19937 rng(3);
  std::vector<Image> clip;
  for (int k = 0; k < 9; ++k) clip.push_back(background(64, 48, rng));
  paint(clip[3], 20, 10, 40, 30, 0.1f, 0.8f, 0.2f);
  const std::vector<Image> masks = background_masks(clip, {0, 2, 4, 6, 8}, {});
  EXPECT_GT(foreground(masks[3], 21, 11, 39, 29), 0.95);
  for (int k : {0, 2, 4, 6, 8}) EXPECT_EQ(foreground(masks[k], 0, 0, 64, 48), 0.0) << k;
}

TEST(BackgroundMasks, RejectsTooFewFramesAndMismatchedSizes) {
  std::mt19937 rng(4);
  std::vector<Image> clip = {background(32, 32, rng), background(32, 32, rng)};
  EXPECT_THROW(background_masks(clip, {0}, {}), Error);
  EXPECT_THROW(background_masks(clip, {0, 2}, {}), Error);
  clip.push_back(background(32, 30, rng));
  try {
    background_masks(clip, {0, 1, 2}, {});
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frame 2 is 32x30"), std::string::npos) << e.what();
  }
}

// On a synthetic scene (static cameras, moving objects) without its masks: prepare writes a mask
// for every camera at every frame, inside the true foreground; the default points stay those of a
// scene without masks, and a re-run keeps the masks.
TEST(PrepareMasks, WritesMasksForEveryFrameAndThePointsUseThem) {
  test::TempDir dir;
  synth::SynthOptions so;
  so.preset = "default";
  so.cameras = 3;
  so.frames = 9;
  so.width = 96, so.height = 72;
  so.progress = false;
  synth::synthesize_scene(so, dir / "scene");
  fs::rename(dir / "scene" / "masks", dir / "truth");
  fs::remove_all(dir / "scene" / "points");
  const io::Scene scene = media::read_scene(dir / "scene");

  PrepareOptions options;
  options.progress = false;
  options.hull.resolution = 48;
  options.colmap.executable = "/nonexistent/colmap";
  options.masks.emplace();
  const PrepareReport r = prepare_scene(scene, options);
  EXPECT_EQ(r.masks_written, 27u);
  EXPECT_EQ(r.masks_kept, 0u);
  EXPECT_GT(r.mask_coverage, 0.0);
  EXPECT_EQ(r.points_source, "random");  // as without masks: these are approximate

  double both = 0, found = 0, truth_area = 0;
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 9; ++k) {
      const std::optional<Image> mask = media::load_mask(scene, c, k);
      ASSERT_TRUE(mask) << c << " " << k;
      const fs::path rel = fs::relative(scene.mask_path(c, k), scene.root / "masks");
      const Image truth = media::read_mask(dir / "truth" / rel);
      for (std::size_t i = 0; i < truth.pixels(); ++i) {
        const bool a = is_foreground(*mask, i), b = is_foreground(truth, i);
        both += a && b;
        found += a;
        truth_area += b;
      }
    }
  // What the masks mark is foreground (precision); they find only what moves over these nine
  // frames, not the objects that turn or swell in place (recall).
  EXPECT_GT(both / found, 0.8) << "precision";
  EXPECT_GT(both / truth_area, 0.2) << "recall";

  const PrepareReport again = prepare_scene(scene, options);
  EXPECT_EQ(again.masks_written, 0u);
  EXPECT_EQ(again.masks_kept, 27u);

  // A plain prepare afterwards keeps the default of a scene without masks: what --masks wrote is
  // marked approximate, so the default does not depend on what an earlier run wrote.
  EXPECT_TRUE(fs::is_regular_file(scene.estimated_masks_marker()));
  fs::remove_all(scene.root / "points");
  options.masks.reset();
  EXPECT_EQ(prepare_scene(scene, options).points_source, "random");
  // Masks brought with the scene (no marker) are the capture's own: the hull uses them.
  fs::remove_all(scene.root / "masks");
  fs::copy(dir / "truth", scene.root / "masks", fs::copy_options::recursive);
  fs::remove_all(scene.root / "points");
  EXPECT_EQ(prepare_scene(scene, options).points_source, "hull,random");
}

}  // namespace
}  // namespace retimegs::prepare
