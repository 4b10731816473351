// export --time / --times: the Gaussians of each time as a 3DGS .ply (a folder of them with
// times.csv), exactly model::export_splats's; a time outside the model's range or a taken output
// is refused with nothing written.
#include <filesystem>

#include <gtest/gtest.h>

#include "playback/two_camera_cloud.hpp"
#include "retimegs/io/splat_ply.hpp"
#include "retimegs/model/export.hpp"
#include "retimegs/playback/export_times.hpp"
#include "test_util.hpp"

namespace retimegs::playback {
namespace {
namespace fs = std::filesystem;
using test::expect_error;

void expect_same(const Splats& a, const Splats& b) {
  EXPECT_EQ(a.size(), b.size());
  EXPECT_EQ(a.means, b.means);
  EXPECT_EQ(a.opacity_logits, b.opacity_logits);
  EXPECT_EQ(a.sh, b.sh);
}

TEST(ExportTimes, AFolderOfPlyFilesAndTheirTimes) {
  const test::TwoCameraCloud f;
  test::TempDir dir;
  export_times(f.model, {0.5, 1.25}, dir / "seq", false);
  EXPECT_EQ(test::read_text(dir / "seq" / "times.csv"), "frame,time\n0,0.5\n1,1.25\n");
  const Splats later = io::read_splat_ply(dir / "seq" / "00001.ply");
  expect_same(later, model::export_splats(f.model, 1.25));
  EXPECT_NE(later.means, io::read_splat_ply(dir / "seq" / "00000.ply").means) << "they move";
  // A time outside the model's range [0, 2] is refused before anything is written.
  expect_error(
      [&] {
        export_times(f.model, {1.0, 2.5}, dir / "bad", false);
      },
      {"export", "2.5", "time range"});
  EXPECT_FALSE(fs::exists(dir / "bad"));
  expect_error([&] { export_times(f.model, {1.0}, dir / "seq", false); }, {"seq"});
  export_times(f.model, {1.0}, dir / "seq", true);
  EXPECT_FALSE(fs::exists(dir / "seq" / "00001.ply")) << "--force replaces the folder";
}

TEST(ExportTimes, OneTimeIsOnePlyFile) {
  const test::TwoCameraCloud f;
  test::TempDir dir;
  EXPECT_EQ(export_time(f.model, 1.0, dir / "t1.ply", false),
            model::export_splats(f.model, 1.0).size());
  expect_same(io::read_splat_ply(dir / "t1.ply"), model::export_splats(f.model, 1.0));
  expect_error([&] { export_time(f.model, 1.0, dir / "t1.png", false); }, {"--out", ".ply"});
  expect_error([&] { export_time(f.model, 1.0, dir / "t1.ply", false); }, {"t1.ply"});
  expect_error([&] { export_time(f.model, -0.5, dir / "t2.ply", false); }, {"export", "-0.5"});
  EXPECT_FALSE(fs::exists(dir / "t2.ply"));
}

}  // namespace
}  // namespace retimegs::playback
