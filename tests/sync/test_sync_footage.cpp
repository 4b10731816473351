// `import videos --sync auto` on a synthetic rig whose cameras run late by known amounts that
// scene.json does not record (synth --time-offsets --unrecorded-offsets): the whole chain from
// the footage's motion to the scene's clocks.
#include <cmath>
#include <filesystem>
#include <map>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "retimegs/ingest/import.hpp"
#include "retimegs/io/rig_file.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/synth/synth.hpp"
#include "test_util.hpp"

namespace retimegs::ingest {
namespace {
namespace fs = std::filesystem;

// cam01 late by half a frame, cam02 by 0.3, cam03 early by 0.4; cam00, the reference, on time.
const std::map<std::string, double> kTrueOffsets = {
    {"cam00", 0}, {"cam01", 0.5}, {"cam02", 0.3}, {"cam03", -0.4}};

struct Recovered {
  VideosReport report;
  io::Scene scene;
  nlohmann::json json;
};

Recovered import_synthetic_rig(const fs::path& dir, std::uint64_t seed) {
  synth::SynthOptions synth;
  synth.preset = "pulsing";
  synth.cameras = 4;
  synth.frames = 25;
  synth.width = 96, synth.height = 72;
  synth.seed = seed;
  synth.time_offsets = kTrueOffsets;
  synth.record_offsets = false;
  synth.progress = false;
  synth::synthesize_scene(synth, dir / "rig");
  const io::Scene rig = io::read_scene_json(dir / "rig");
  EXPECT_TRUE(rig.clocks.empty());  // the offsets are the footage's alone
  io::write_rig_file(dir / "rig.json", rig.cameras);

  ImportOptions options;
  options.progress = false;
  VideosOptions videos;
  videos.calibration = dir / "rig.json";
  videos.sync_auto = true;
  Recovered out;
  out.report = import_videos(dir / "rig" / "images", dir / "scene", options, videos);
  out.scene = io::read_scene_json(dir / "scene");
  out.json = nlohmann::json::parse(test::read_text(dir / "scene" / "scene.json"));
  return out;
}

// Camera c's frames show scene time k + o: its estimated --offsets value is -o, and the scene's
// clock says frame k of it shows k + o up to the whole frames the import shifted it by, within a
// tenth of a frame: a camera's motion energy is its own view's, which weighs the sphere's texture
// differently, and a sphere reversing its motion makes kinks where interpolation errs (seeds 1 to
// 12: 0.09 at worst; 17 frames instead of 25 leave too few to average that out).
TEST(SyncFootage, RecoversTheRigsOffsetsAndWritesThemAsEstimatedClocks) {
  test::TempDir dir;
  const Recovered r = import_synthetic_rig(dir.path(), 1);
  EXPECT_EQ(r.scene.clock_source, io::ClockSource::kEstimated);
  ASSERT_EQ(r.report.sync.size(), 4u);
  ASSERT_EQ(r.scene.clocks.size(), 4u);
  for (std::size_t c = 0; c < 4; ++c) {
    const auto& cam = r.report.sync[c];
    const double truth = kTrueOffsets.at(cam.name);
    EXPECT_NEAR(cam.offset, -truth, 0.1) << cam.name << " peak " << cam.peak;
    EXPECT_EQ(cam.weak, "") << cam.name;
    // scene.json: frame k is source frame k + source.offset, at time k + time_offset.
    const double clock =
        r.scene.clocks[c].time_offset - r.json["cameras"][c]["source"]["offset"].get<int>();
    EXPECT_NEAR(clock, truth, 0.1) << cam.name;
  }
}

}  // namespace
}  // namespace retimegs::ingest
