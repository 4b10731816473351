#include <algorithm>
#include <cmath>
#include <functional>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "retimegs/core/error.hpp"
#include "retimegs/eval/lpips.hpp"
#include "retimegs/io/npy.hpp"
#include "retimegs/media/image_io.hpp"
#include "test_util.hpp"

namespace retimegs::eval {
namespace {

constexpr const char* kData = "metrics/lpips_squeeze";

// data/metrics/lpips_squeeze/reference_values.json, "numpy_float64_reimplementation" (the official
// float32 code agrees within 1.7e-7).
constexpr double kRefP0 = 0.7110476441575679, kRefP1 = 0.1479015802166158;
constexpr double kTapsP0[Lpips::kTaps] = {
    0.009890696542105662, 0.006902858098714193, 0.12881015950511887, 0.2609783435650176,
    0.15068102508923298,  0.08814192999980161,  0.06564263135757703};

const std::filesystem::path& data_dir() {
  static const std::filesystem::path dir = test::shared_data() / kData;
  return dir;
}

// The repository's copy (eval's default), loaded once for the whole suite (57 files, 2.9 MB);
// the reference distances below check it.
const Lpips& reference_lpips() {
  static const Lpips lpips = Lpips::load(RETIMEGS_LPIPS_WEIGHTS);
  return lpips;
}

Image read(const char* name) {
  return media::read_image(data_dir() / name);
}

using test::message_of;

TEST(Lpips, ReproducesTheReferenceDistances) {
  RETIMEGS_REQUIRE_DATA(kData);
  const Lpips& lpips = reference_lpips();
  const Image ref = read("ex_ref.png"), p0 = read("ex_p0.png"), p1 = read("ex_p1.png");
  const double d0 = lpips.distance(ref, p0), d1 = lpips.distance(ref, p1);
  EXPECT_NEAR(d0, kRefP0, 1e-6);
  EXPECT_NEAR(d1, kRefP1, 1e-6);
  RecordProperty("error_p0", fmt::format("{:.3e}", d0 - kRefP0));
  RecordProperty("error_p1", fmt::format("{:.3e}", d1 - kRefP1));
  const auto taps = lpips.tap_distances(ref, p0);
  for (int t = 0; t < Lpips::kTaps; ++t) EXPECT_NEAR(taps[t], kTapsP0[t], 1e-6) << "tap " << t;
  EXPECT_EQ(lpips.distance(p0, ref), d0);  // symmetric
  EXPECT_EQ(lpips.distance(ref, ref), 0.0);
}

TEST(Lpips, TapActivationsMatchTheReference) {
  RETIMEGS_REQUIRE_DATA(kData);
  const auto taps = reference_lpips().features(read("ex_ref.png"));
  for (int t = 0; t < Lpips::kTaps; ++t) {
    const auto file = data_dir() / "activations_ex_ref" / fmt::format("tap{}.npy", t);
    const io::NpyArray ref = io::read_npy(file);
    const FeatureMap& f = taps[t];
    ASSERT_EQ(ref.shape, (std::vector<std::size_t>{std::size_t(f.channels), std::size_t(f.height),
                                                   std::size_t(f.width)}))
        << file;
    double largest = 0, worst = 0;
    for (std::size_t i = 0; i < ref.size(); ++i) {
      largest = std::max(largest, std::abs(ref.values[i]));
      worst = std::max(worst, std::abs(f.data[i] - ref.values[i]));
    }
    EXPECT_GT(largest, 0.0);
    EXPECT_LT(worst, 1e-5 * largest) << "tap " << t;
    RecordProperty(fmt::format("tap{}_relative_error", t), fmt::format("{:.2e}", worst / largest));
  }
}

// 66 px makes every max pool see an input of odd (L − 3), where ceil_mode keeps a last, clipped
// window: 66 → conv 32 → 16 → 8 → 4 (floor mode: 15, 7, 3). 40 px: 19 → 9 → 4 → 2 (floor: 1).
TEST(Lpips, PoolsUseCeilMode) {
  RETIMEGS_REQUIRE_DATA(kData);
  const auto taps = reference_lpips().features(Image(66, 40, 3, 0.5f));
  const int expected[Lpips::kTaps][3] = {{64, 19, 32}, {128, 9, 16}, {256, 4, 8}, {384, 2, 4},
                                         {384, 2, 4},  {512, 2, 4},  {512, 2, 4}};
  for (int t = 0; t < Lpips::kTaps; ++t) {
    EXPECT_EQ(taps[t].channels, expected[t][0]) << "tap " << t;
    EXPECT_EQ(taps[t].height, expected[t][1]) << "tap " << t;
    EXPECT_EQ(taps[t].width, expected[t][2]) << "tap " << t;
  }
}

TEST(Lpips, RejectsBadImages) {
  RETIMEGS_REQUIRE_DATA(kData);
  const Lpips& lpips = reference_lpips();
  const Image rgb(32, 32, 3, 0.5f);
  EXPECT_NE(message_of([&] { lpips.distance(rgb, Image(32, 32, 1)); }).find("32x32x3 vs 32x32x1"),
            std::string::npos);
  EXPECT_NE(
      message_of([&] { lpips.distance(Image(24, 40, 3), Image(24, 40, 3)); }).find("too small"),
      std::string::npos);
  EXPECT_NO_THROW(lpips.distance(Image(25, 25, 3), Image(25, 25, 3)));
  Image nan = rgb;
  nan.at(3, 4, 1) = std::nanf("");
  EXPECT_NE(message_of([&] { lpips.distance(rgb, nan); }).find("pixel (4, 3)"), std::string::npos);
}

TEST(Lpips, MissingWeightsThrowNamingThem) {
  const std::string missing = "/nonexistent/lpips-weights";
  EXPECT_NE(message_of([&] { Lpips::load(missing); }).find(missing), std::string::npos);
  const test::TempDir empty;  // a folder without the .npy files
  EXPECT_NE(message_of([&] { Lpips::load(empty.path()); }).find("features.0.weight.npy"),
            std::string::npos);
}

}  // namespace
}  // namespace retimegs::eval
