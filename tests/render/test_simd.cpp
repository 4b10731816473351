// The simd helpers whose lane bookkeeping is easy to get wrong: row <-> column transposes.
#include <gtest/gtest.h>

#include <numeric>
#include <vector>

#include "render/simd.hpp"

namespace retimegs::render {
namespace {

template <int W>
void check_transpose() {
  constexpr int kLanes = simd::kLanes;
  std::vector<float> rows(kLanes * W);  // [16, W]
  std::iota(rows.begin(), rows.end(), 1.0f);
  simd::vf columns[W];
  simd::load_columns<W>(rows.data(), columns);
  for (int l = 0; l < kLanes; ++l)
    for (int k = 0; k < W; ++k)
      EXPECT_EQ(columns[k][l], rows[W * l + k]) << "W " << W << " row " << l << " component " << k;
  std::vector<float> back(rows.size(), -1.0f);
  simd::store_columns<W>(back.data(), columns);
  EXPECT_EQ(back, rows) << "W " << W;
}

TEST(RenderSimd, ColumnsOfRowsRoundTrip) {
  check_transpose<1>();
  check_transpose<2>();
  check_transpose<3>();
  check_transpose<4>();
}

}  // namespace
}  // namespace retimegs::render
