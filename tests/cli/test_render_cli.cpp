// `retimegs render --model splat.ply`: a static 3DGS file rendered through the CLI equals the
// library render (quantised to 8 bits), and bad models are refused with one line and status 2.
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "retimegs/core/error.hpp"
#include "retimegs/io/npy.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/io/splat_ply.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/model/sh.hpp"
#include "retimegs/model/static_splats.hpp"
#include "retimegs/render/rasterize.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;

// The gsplat reference case 2 (2000 garden Gaussians, 160x120) as an Inria .ply: colours become
// the SH DC term, opacities logits, scales logs; and a one-camera scene with its view matrix.
struct Fixture {
  Splats splats;
  io::Scene scene;
};

Fixture gsplat_case_as_ply(const fs::path& root) {
  const fs::path dir = test::shared_data() / "gsplat-reference" / "case2_n2000_160x120";
  const auto means = io::read_npy(dir / "means.npy").to_float();
  const auto scales = io::read_npy(dir / "scales.npy").to_float();
  const auto quats = io::read_npy(dir / "quats.npy").to_float();
  const auto colors = io::read_npy(dir / "colors.npy").to_float();
  const auto opacities = io::read_npy(dir / "opacities.npy").to_float();
  const auto view = io::read_npy(dir / "viewmat.npy").values;
  const auto intr = io::read_npy(dir / "intrinsics.npy").values;
  Fixture f;
  Splats& s = f.splats;
  const std::size_t n = opacities.size();
  s.sh_degree = 0;
  s.means = means;
  s.quats = quats;
  s.log_scales.resize(3 * n);
  for (std::size_t i = 0; i < 3 * n; ++i) s.log_scales[i] = std::log(scales[i]);
  s.opacity_logits.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const float o = std::clamp(opacities[i], 1e-6f, 1 - 1e-6f);
    s.opacity_logits[i] = std::log(o / (1 - o));
  }
  s.sh.resize(3 * n);
  for (std::size_t i = 0; i < 3 * n; ++i) s.sh[i] = float((colors[i] - 0.5) / model::kShC0);

  io::Scene& scene = f.scene;
  scene.root = root;
  scene.num_frames = 1;
  scene.fps = 1;
  Camera cam;
  cam.name = "garden";
  cam.width = 160, cam.height = 120;
  cam.fx = intr[0], cam.fy = intr[1], cam.cx = intr[2], cam.cy = intr[3];
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) cam.world_to_camera(r, c) = view[4 * r + c];
  scene.cameras.push_back(cam);
  io::write_scene_json(scene);
  return f;
}

TEST(RenderCli, StaticPlyMatchesLibraryRender) {
  RETIMEGS_REQUIRE_DATA("gsplat-reference/case2_n2000_160x120");
  test::TempDir dir;
  const Fixture f = gsplat_case_as_ply(dir / "scene");
  io::write_splat_ply(dir / "splat.ply", f.splats);
  const auto r = test::run_cli("render --model " + (dir / "splat.ply").string() + " --scene " +
                               (dir / "scene").string() + " --camera garden --time 0 --out " +
                               (dir / "out.png").string() + " --background 1,1,1");
  ASSERT_EQ(r.status, 0) << r.err;
  const Image cli = media::read_image(dir / "out.png");
  const Camera& cam = f.scene.cameras[0];
  const float background[3] = {1, 1, 1};
  const auto lib =
      render::rasterize_forward(model::splats_to_gaussians(f.splats, cam), cam, background);
  ASSERT_EQ(cli.data.size(), lib.blend.image.data.size());
  double max_err = 0, mean = 0;
  for (std::size_t i = 0; i < cli.data.size(); ++i) {
    const float expected = std::clamp(lib.blend.image.data[i], 0.0f, 1.0f);
    max_err = std::max(max_err, double(std::abs(cli.data[i] - expected)));
    mean += cli.data[i];
  }
  EXPECT_LE(max_err, 0.5 / 255 + 1e-6);  // 8-bit rounding only
  // Not a blank image: the reference render averages 0.833 over a white background.
  EXPECT_NEAR(mean / cli.data.size(), 0.833, 0.01);
}

TEST(RenderCli, BadModelOrCameraExitsTwo) {
  RETIMEGS_REQUIRE_DATA("gsplat-reference/case2_n2000_160x120");
  test::TempDir dir;
  const Fixture f = gsplat_case_as_ply(dir / "scene");
  io::write_splat_ply(dir / "splat.ply", f.splats);
  const std::string text = test::read_text(dir / "splat.ply");
  test::write_text(dir / "cut.ply", text.substr(0, text.size() - 100));
  const std::string scene = " --scene " + (dir / "scene").string();
  const std::string out = " --time 0 --out " + (dir / "out.png").string();
  struct Case {
    std::string args, fragment;
  };
  for (const Case& c :
       {Case{"--model " + (dir / "cut.ply").string() + scene + " --camera garden", "cut.ply"},
        Case{"--model " + (dir / "none.ply").string() + scene + " --camera garden", "none.ply"},
        Case{"--model " + (dir / "splat.ply").string() + scene + " --camera nope", "nope"}}) {
    const auto r = test::run_cli("render " + c.args + out);
    EXPECT_EQ(r.status, 2) << c.args;
    EXPECT_NE(r.err.find(c.fragment), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out.png"));
  }
}

}  // namespace
}  // namespace retimegs
