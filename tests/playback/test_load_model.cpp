// Which model a file holds (a .ply is a static 3DGS model, anything else a 4D model, a window
// model as it was trained), and the near plane of a command's renders.
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "playback/two_camera_cloud.hpp"
#include "retimegs/io/splat_ply.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/model/export.hpp"
#include "retimegs/playback/render_model.hpp"
#include "test_util.hpp"

namespace retimegs::playback {
namespace {
using test::expect_error;

TEST(LoadModel, AWindowModelIsReadOverItsOwnFrames) {
  test::TempDir dir;
  model::Model clip = test::TwoCameraCloud().model;
  clip.grid = {0.0, 1.0, 5};              // training frames 0..4
  clip.window = model::TimeWindow{1, 3};  // trained on frames 1..3
  model::write_model(dir / "window.rgs", clip);
  const model::Model m = read_4d_model(dir / "window.rgs");
  EXPECT_EQ(m.grid.first, 1.0);
  EXPECT_EQ(m.grid.last(), 3.0);
  EXPECT_FALSE(m.window);
  const LoadedModel loaded = load_model(dir / "window.rgs");
  ASSERT_TRUE(std::holds_alternative<model::Model>(loaded));
  EXPECT_EQ(std::get<model::Model>(loaded).grid.first, 1.0);
}

TEST(LoadModel, APlyFileIsAStaticModel) {
  test::TempDir dir;
  const test::TwoCameraCloud f;
  io::write_splat_ply(dir / "static.ply", model::export_splats(f.model, 1.0));
  const LoadedModel loaded = load_model(dir / "static.ply");
  ASSERT_TRUE(std::holds_alternative<Splats>(loaded));
  EXPECT_EQ(std::get<Splats>(loaded).size(), model::export_splats(f.model, 1.0).size());
  expect_error([&] { load_model(dir.path()); }, {dir.path().string()});  // a folder
}

TEST(NearPlane, GivenOrTheScenes) {
  const test::TwoCameraCloud f;
  EXPECT_EQ(near_plane(0.25, f.scene), 0.25);
  EXPECT_GT(io::scene_near_plane(f.scene), 0.0);
  EXPECT_EQ(near_plane({}, f.scene), io::scene_near_plane(f.scene));
  for (const double bad : {0.0, -1.0, std::nan(""), double(INFINITY)})
    expect_error([&] { near_plane(bad, f.scene); }, {"--near"});
  EXPECT_EQ(near_render_options(0.25).near_plane, 0.25f);
}

}  // namespace
}  // namespace retimegs::playback
