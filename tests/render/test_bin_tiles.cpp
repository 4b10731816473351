// bin_tiles computes the tile rects 16 Gaussians at a time; they must be blend_tile_rect's.
#include <gtest/gtest.h>

#include "render_test_util.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/render/bin_tiles.hpp"
#include "retimegs/render/project.hpp"

namespace retimegs::test {
namespace {

TEST(RenderBinTiles, EveryGaussianIsInExactlyTheTilesOfItsBlendTileRect) {
  const Camera camera = test_camera(173, 94);  // 11 x 6 tiles, partial ones on two sides
  Gaussians g = cast_gaussians<float>(random_gaussians<double>(camera, 2001, 3, 31, 12.0));
  g.opacities[5] = 1.0f / 255.0f;  // level 0: binned into its centre's tile alone
  for (const bool tight : {false, true}) {
    render::RenderOptions options;
    options.tight_tile_bounds = tight;
    const render::Projected p =
        render::project_forward(g, render::PinholeT<float>(camera), options);
    const render::TileBins bins =
        render::bin_tiles(p, g.opacities.data(), camera.width, camera.height, options);
    std::vector<std::vector<int>> tiles_of(g.size());  // [N] tiles each Gaussian is binned into
    for (int t = 0; t < bins.num_tiles(); ++t)
      for (int m = bins.isect_offsets[t]; m < bins.isect_offsets[t + 1]; ++m)
        tiles_of[bins.gaussian_from_isect[m]].push_back(t);
    int binned = 0;
    for (std::size_t i = 0; i < g.size(); ++i) {
      std::vector<int> expected;
      if (p.radii[i] > 0) {
        const render::TileRect r =
            render::blend_tile_rect(&p.means2d[2 * i], &p.conics[3 * i], p.radii[i], g.opacities[i],
                                    bins.tiles_x, bins.tiles_y, options);
        for (int ty = r.y0; ty < r.y1; ++ty)
          for (int tx = r.x0; tx < r.x1; ++tx) expected.push_back(ty * bins.tiles_x + tx);
      }
      ASSERT_EQ(tiles_of[i], expected) << "Gaussian " << i << ", tight " << tight;
      binned += !expected.empty();
    }
    EXPECT_GT(binned, int(g.size()) / 2);
  }
}

// Enough Gaussians that every pass splits over the threads (with ties in depth and more than one
// radix pass): each tile's list is front to back, ties by index, and 1 and 2 threads agree.
TEST(RenderBinTiles, TileListsAreInDepthOrderForAnyThreadCount) {
  const Camera camera = test_camera(300, 200);
  Gaussians g = cast_gaussians<float>(random_gaussians<double>(camera, 20001, 3, 32, 12.0));
  render::RenderOptions options;
  const render::Projected p = render::project_forward(g, render::PinholeT<float>(camera), options);
  UninitVector<float> depths = p.depths;
  for (std::size_t i = 0; i + 1 < depths.size(); i += 7) depths[i + 1] = depths[i];  // ties
  render::Projected tied = p;
  tied.depths = depths;
  const int threads_before = max_threads();
  std::vector<render::TileBins> bins;
  for (const int threads : {1, 2}) {
    set_threads(threads);
    bins.push_back(
        render::bin_tiles(tied, g.opacities.data(), camera.width, camera.height, options));
  }
  set_threads(threads_before);
  EXPECT_EQ(bins[0].isect_offsets, bins[1].isect_offsets);
  EXPECT_EQ(bins[0].gaussian_from_isect, bins[1].gaussian_from_isect);
  const render::TileBins& b = bins[1];
  EXPECT_GT(b.num_intersections(), g.size());
  for (int t = 0; t < b.num_tiles(); ++t)
    for (int m = b.isect_offsets[t] + 1; m < b.isect_offsets[t + 1]; ++m) {
      const std::int32_t front = b.gaussian_from_isect[m - 1], back = b.gaussian_from_isect[m];
      ASSERT_TRUE(depths[front] < depths[back] || (depths[front] == depths[back] && front < back))
          << "tile " << t << ", intersection " << m;
    }
}

}  // namespace
}  // namespace retimegs::test
