#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/io/flow_io.hpp"
#include "retimegs/media/image_io.hpp"
#include "test_util.hpp"

namespace retimegs::io {
namespace {
using test::read_text;
using test::shared_data;
using test::TempDir;
using test::write_text;

using test::expect_error;

nlohmann::json reference(const std::string& key) {
  return nlohmann::json::parse(read_text(shared_data() / "flow/reference_values.json")).at(key);
}

// Independent parse of a .flo file: [tag, width, height] then the raw float pairs.
struct RawFlo {
  int width = 0, height = 0;
  std::vector<float> uv;
};
RawFlo raw_flo(const std::filesystem::path& path) {
  const std::string bytes = read_text(path);
  RawFlo raw;
  std::memcpy(&raw.width, bytes.data() + 4, 4);
  std::memcpy(&raw.height, bytes.data() + 8, 4);
  raw.uv.resize((bytes.size() - 12) / 4);
  std::memcpy(raw.uv.data(), bytes.data() + 12, raw.uv.size() * 4);
  return raw;
}

// EPE of the zero flow: mean |GT| over the pixels with valid && keep[i].
struct ZeroFlowEpe {
  std::size_t count = 0;
  double epe = 0, max_magnitude = 0;
};
ZeroFlowEpe zero_flow_epe(const Flow& gt, const std::vector<bool>& keep = {}) {
  ZeroFlowEpe r;
  for (std::size_t i = 0; i < gt.pixels(); ++i) {
    if (!gt.valid[i] || (!keep.empty() && !keep[i])) continue;
    const double m = std::hypot(double(gt.uv[2 * i]), double(gt.uv[2 * i + 1]));
    r.epe += m;
    r.max_magnitude = std::max(r.max_magnitude, m);
    ++r.count;
  }
  r.epe /= double(r.count);
  return r;
}

TEST(FlowIo, RubberWhaleUnknownPixelsMatchRawFile) {
  RETIMEGS_REQUIRE_DATA("flow/middlebury-rubberwhale/flow10.flo");
  const auto path = shared_data() / "flow/middlebury-rubberwhale/flow10.flo";
  const Flow flow = read_flo(path);
  EXPECT_EQ(flow.width, 584);
  EXPECT_EQ(flow.height, 388);
  const RawFlo raw = raw_flo(path);
  ASSERT_EQ(raw.uv.size(), flow.uv.size());
  std::size_t unknown = 0;
  for (std::size_t i = 0; i < flow.pixels(); ++i) {
    const float u = raw.uv[2 * i], v = raw.uv[2 * i + 1];
    if (std::abs(u) > 1e9f || std::abs(v) > 1e9f) {
      ++unknown;
      ASSERT_EQ(flow.valid[i], 0) << i;
      ASSERT_EQ(flow.uv[2 * i], 0.0f);
      ASSERT_EQ(flow.uv[2 * i + 1], 0.0f);
    } else {
      ASSERT_EQ(flow.valid[i], 1) << i;
      ASSERT_EQ(flow.uv[2 * i], u) << i;
      ASSERT_EQ(flow.uv[2 * i + 1], v) << i;
    }
  }
  const nlohmann::json ref = reference("middlebury-rubberwhale");
  EXPECT_EQ(flow.pixels() - unknown, ref.at("n_valid").get<std::size_t>());
  const ZeroFlowEpe e = zero_flow_epe(flow);
  EXPECT_EQ(e.count, 222970u);
  EXPECT_NEAR(e.epe, ref.at("epe_zero_flow").get<double>(), 1e-4);
  EXPECT_NEAR(e.epe, 1.2560, 1e-4);
  EXPECT_NEAR(e.max_magnitude, ref.at("gt_max_mag").get<double>(), 1e-5);
}

TEST(FlowIo, SintelZeroFlowEpeWithInvalidAndOcclusionMasks) {
  RETIMEGS_REQUIRE_DATA("flow/sintel-alley_1-clean");
  const auto dir = shared_data() / "flow/sintel-alley_1-clean";
  const Flow flow = read_flo(dir / "flow_0002.flo");
  EXPECT_EQ(flow.width, 1024);
  EXPECT_EQ(flow.height, 436);
  EXPECT_EQ(std::count(flow.valid.begin(), flow.valid.end(), 1), 1024 * 436);  // no unknowns
  const Image invalid = media::read_mask(dir / "invalid_0002.png");
  const Image occluded = media::read_mask(dir / "occlusions_0002.png");
  ASSERT_EQ(invalid.pixels(), flow.pixels());
  std::vector<bool> all(flow.pixels()), noc(flow.pixels());
  for (std::size_t i = 0; i < flow.pixels(); ++i) {
    all[i] = invalid.data[i] == 0.0f;
    noc[i] = all[i] && occluded.data[i] == 0.0f;
  }
  const nlohmann::json ref = reference("sintel-alley_1-clean");
  const ZeroFlowEpe e_all = zero_flow_epe(flow, all), e_noc = zero_flow_epe(flow, noc);
  EXPECT_EQ(e_all.count, 446384u);
  EXPECT_NEAR(e_all.epe, ref.at("epe_zero_flow").get<double>(), 1e-4);
  EXPECT_EQ(e_noc.count, ref.at("n_noc").get<std::size_t>());
  EXPECT_NEAR(e_noc.epe, ref.at("epe_zero_flow_noc").get<double>(), 1e-4);
}

TEST(FlowIo, FullyKnownFilesMatchReferenceZeroFlowEpe) {
  RETIMEGS_REQUIRE_DATA("flow/flyingchairs");
  for (const auto& [key, file] : {std::pair{"flyingchairs/0000000", "flyingchairs/0000000-gt.flo"},
                                  {"flyingchairs/0000004", "flyingchairs/0000004-gt.flo"},
                                  {"middlebury-urban", "middlebury-urban/flow10.flo"}}) {
    const Flow flow = read_flo(shared_data() / "flow" / file);
    const nlohmann::json ref = reference(key);
    EXPECT_EQ(flow.width, ref.at("width").get<int>()) << key;
    EXPECT_EQ(flow.height, ref.at("height").get<int>()) << key;
    const ZeroFlowEpe e = zero_flow_epe(flow);
    EXPECT_EQ(e.count, ref.at("n_valid").get<std::size_t>()) << key;
    EXPECT_NEAR(e.epe, ref.at("epe_zero_flow").get<double>(), 1e-4) << key;
    EXPECT_NEAR(e.max_magnitude, ref.at("gt_max_mag").get<double>(), 1e-4) << key;
  }
}

TEST(FlowIo, RoundTripKeepsUnknownPixels) {
  TempDir dir;
  Flow flow(7, 5);
  for (std::size_t i = 0; i < flow.pixels(); ++i) {
    flow.uv[2 * i] = 0.37f * float(i) - 3.0f;
    flow.uv[2 * i + 1] = -1.25f * float(i % 7) + 1e-3f;
  }
  for (const std::size_t i : {0, 9, 34}) {
    flow.valid[i] = 0;
    flow.uv[2 * i] = flow.uv[2 * i + 1] = std::numeric_limits<float>::quiet_NaN();  // ignored
  }
  write_flo(dir / "f.flo", flow);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 1);
  const RawFlo raw = raw_flo(dir / "f.flo");
  EXPECT_EQ(raw.width, 7);
  EXPECT_EQ(raw.height, 5);
  EXPECT_EQ(raw.uv[2 * 9], 1e10f);
  EXPECT_EQ(raw.uv[2 * 9 + 1], 1e10f);
  const Flow back = read_flo(dir / "f.flo");
  EXPECT_EQ(back.valid, flow.valid);
  for (std::size_t i = 0; i < flow.pixels(); ++i) {
    EXPECT_EQ(back.uv[2 * i], flow.valid[i] ? flow.uv[2 * i] : 0.0f) << i;
    EXPECT_EQ(back.uv[2 * i + 1], flow.valid[i] ? flow.uv[2 * i + 1] : 0.0f) << i;
  }
}

TEST(FlowIo, WriteRejectsNonFiniteKnownPixels) {
  TempDir dir;
  Flow flow(3, 2);
  flow.uv[2 * 4 + 1] = std::numeric_limits<float>::infinity();
  expect_error([&] { write_flo(dir / "f.flo", flow); }, {"f.flo", "pixel (1, 1)"});
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

TEST(FlowIo, TruncatedFileIsError) {
  RETIMEGS_REQUIRE_DATA("flow/middlebury-rubberwhale/flow10.flo");
  TempDir dir;
  const std::string bytes = read_text(shared_data() / "flow/middlebury-rubberwhale/flow10.flo");
  write_text(dir / "cut.flo", bytes.substr(0, bytes.size() - 4));
  const std::string path = (dir / "cut.flo").string();
  expect_error([&] { read_flo(path); },
               {path, "truncated", "expected 1812748 bytes, found 1812744"});
  write_text(dir / "head.flo", bytes.substr(0, 8));
  expect_error([&] { read_flo(dir / "head.flo"); }, {"head.flo", "truncated"});
}

TEST(FlowIo, HeaderProblemsAreErrors) {
  TempDir dir;
  Flow flow(2, 2);
  write_flo(dir / "ok.flo", flow);
  const std::string good = read_text(dir / "ok.flo");

  std::string bad_tag = good;
  bad_tag[0] = 'X';
  write_text(dir / "tag.flo", bad_tag);
  expect_error([&] { read_flo(dir / "tag.flo"); }, {"tag.flo", "bad .flo tag"});

  std::string bad_size = good;
  const std::int32_t negative = -2;
  std::memcpy(bad_size.data() + 4, &negative, 4);
  write_text(dir / "size.flo", bad_size);
  expect_error([&] { read_flo(dir / "size.flo"); }, {"size.flo", "invalid .flo size -2x2"});

  std::string nan = good;
  const float q = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(nan.data() + 12 + 8 * 3, &q, 4);  // u of pixel (1, 1)
  write_text(dir / "nan.flo", nan);
  expect_error([&] { read_flo(dir / "nan.flo"); }, {"nan.flo", "NaN", "(1, 1)"});

  write_text(dir / "long.flo", good + "xxxx");
  expect_error([&] { read_flo(dir / "long.flo"); }, {"long.flo", "trailing"});
  expect_error([&] { read_flo(dir / "missing.flo"); }, {"missing.flo", "no such file"});
}

// The declared size is checked against the file's size before allocating (issue 26).
TEST(FlowIo, DeclaredSizeBeyondTheFileIsRefusedNamingIt) {
  TempDir dir;
  struct Case {
    const char* name;
    std::int32_t width, height;
    const char* fragment;
  };
  const Case cases[] = {
      {"big", 60000, 60000, "truncated .flo (expected 28800000012 bytes, found 20)"},
      {"wide", 65536, 1, "invalid .flo size 65536x1"},
      {"max", INT32_MAX, INT32_MAX, "invalid .flo size 2147483647x2147483647"},
      {"zero", 0, 7, "invalid .flo size 0x7"},
  };
  for (const Case& c : cases) {
    std::string bytes(20, '\0');
    const float tag = 202021.25f;
    std::memcpy(bytes.data(), &tag, 4);
    std::memcpy(bytes.data() + 4, &c.width, 4);
    std::memcpy(bytes.data() + 8, &c.height, 4);
    const auto path = dir / (std::string(c.name) + ".flo");
    write_text(path, bytes);
    SCOPED_TRACE(c.name);
    expect_error([&] { read_flo(path); }, {path.string(), c.fragment});
  }
}

}  // namespace
}  // namespace retimegs::io
