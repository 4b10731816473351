#include <sys/stat.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "io/small_scene.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/io/flow_io.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"
#include "test_util.hpp"

namespace retimegs::io {
namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;
using test::write_small_scene;
// The scene's image files are media's (media/scene_images.hpp), its JSON io's.
using media::load_image;
using media::load_mask;
using media::read_scene;
using media::write_png;

json read_json(const fs::path& path) {
  return json::parse(test::read_text(path));
}
void write_json(const fs::path& path, const json& j) {
  test::write_text(path, j.dump(1));
}

// Expects read_scene to throw an Error whose message contains every fragment.
void expect_scene_error(const fs::path& root, std::initializer_list<std::string> fragments) {
  try {
    read_scene(root);
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string message = e.what();
    for (const auto& f : fragments) EXPECT_NE(message.find(f), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << "one line: " << message;
  }
}

TEST(Scene, WriteReadRoundTrip) {
  test::TempDir dir;
  const Scene written = write_small_scene(dir / "scene");
  const Scene read = read_scene(dir / "scene");
  EXPECT_EQ(read.num_frames, 3);
  EXPECT_DOUBLE_EQ(read.fps, 12.5);
  EXPECT_EQ(read.up, Eigen::Vector3d(0, 0, 1));
  ASSERT_EQ(read.cameras.size(), 2u);
  for (int c = 0; c < 2; ++c) {
    const Camera &a = written.cameras[c], &b = read.cameras[c];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.height, b.height);
    EXPECT_EQ(a.fx, b.fx);
    EXPECT_EQ(a.cy, b.cy);
    EXPECT_EQ(a.split, b.split);
    EXPECT_EQ((a.world_to_camera - b.world_to_camera).cwiseAbs().maxCoeff(), 0.0);
  }
  EXPECT_EQ(read.camera_index("7"), 1);
  EXPECT_THROW(read.camera_index("nope"), Error);
  const Image image = load_image(read, 1, 2);
  EXPECT_EQ(image.width, 12);
  EXPECT_NEAR(image.data[5], float((5 * 7 + 2) % 256) / 255, 1e-6);
  EXPECT_TRUE(load_mask(read, 0, 1).has_value());
  EXPECT_FALSE(load_mask(read, 1, 1).has_value());
  const auto flow = load_flow(read, 0, 0, 1);
  ASSERT_TRUE(flow.has_value());
  EXPECT_EQ(flow->uv[0], 1.5f);
  EXPECT_EQ(flow->valid[3], 0);
  EXPECT_FALSE(load_flow(read, 0, 1, 0).has_value());
  EXPECT_FALSE(load_points(read, 0).has_value());
}

TEST(Scene, MissingFolderAndFile) {
  test::TempDir dir;
  expect_scene_error(dir / "nope", {"nope", "does not exist"});
  fs::create_directories(dir / "empty");
  expect_scene_error(dir / "empty", {"scene.json", "cannot open"});
}

// A FIFO (or a folder) where scene.json should be is refused instead of blocking forever.
TEST(Scene, SceneJsonThatIsNotARegularFile) {
  test::TempDir dir;
  write_small_scene(dir / "s");
  fs::remove(dir / "s" / "scene.json");
  ASSERT_EQ(::mkfifo((dir / "s" / "scene.json").c_str(), 0600), 0);
  expect_scene_error(dir / "s", {"scene.json", "not a regular file"});
  fs::remove(dir / "s" / "scene.json");
  fs::create_directory(dir / "s" / "scene.json");
  expect_scene_error(dir / "s", {"scene.json", "not a regular file"});
}

TEST(Scene, CameraNamesAreSinglePathComponents) {
  for (const char* name : {"..", ".", "a/b", "../x", "", "a\\b", "tab\there"})
    EXPECT_THROW(io::check_camera_name(name, "scene.json"), Error) << name;
  for (const char* name : {"cam00", "0", "left.1", "A_b-c"})
    EXPECT_NO_THROW(io::check_camera_name(name, "scene.json")) << name;
  EXPECT_NO_THROW(io::check_camera_name(std::string(255, 'c'), "scene.json"));
  test::expect_error([] { io::check_camera_name(std::string(256, 'c'), "scene.json"); },
                     {"scene.json", "at most 255 bytes"});
  test::TempDir dir;
  write_small_scene(dir / "s");
  auto j = nlohmann::json::parse(test::read_text(dir / "s" / "scene.json"));
  j["cameras"][0]["name"] = "../outside";
  test::write_text(dir / "s" / "scene.json", j.dump());
  expect_scene_error(dir / "s", {"scene.json", "cameras[0].name", "camera name '../outside'"});
}

TEST(Scene, MalformedJson) {
  test::TempDir dir;
  write_small_scene(dir / "s");
  test::write_text(dir / "s" / "scene.json", "{\"format\": \"retimegs-scene\", ");
  expect_scene_error(dir / "s", {"scene.json", "malformed JSON"});
}

TEST(Scene, MissingRequiredKeys) {
  test::TempDir dir;
  write_small_scene(dir / "s");
  const json good = read_json(dir / "s" / "scene.json");
  for (const char* key : {"format", "version", "num_frames", "fps", "cameras"}) {
    json j = good;
    j.erase(key);
    write_json(dir / "s" / "scene.json", j);
    expect_scene_error(dir / "s", {"scene.json", "missing required key", key});
  }
  for (const char* key : {"name", "width", "height", "fx", "fy", "cx", "cy", "world_to_camera"}) {
    json j = good;
    j["cameras"][1].erase(key);
    write_json(dir / "s" / "scene.json", j);
    expect_scene_error(dir / "s", {"missing required key", std::string("cameras[1].") + key});
  }
}

TEST(Scene, NonFiniteAndInvalidNumbers) {
  test::TempDir dir;
  write_small_scene(dir / "s");
  const json good = read_json(dir / "s" / "scene.json");
  const fs::path file = dir / "s" / "scene.json";
  {
    // JSON has no NaN literal; a string or null in a numeric field is the realistic failure.
    json j = good;
    j["cameras"][0]["fx"] = "nan";
    write_json(file, j);
    expect_scene_error(dir / "s", {"cameras[0].fx", "must be a number"});
  }
  {
    std::string text = good.dump();
    const std::string key = "\"fy\":11.0";
    text.replace(text.find(key), key.size(), "\"fy\":1e999");  // overflows double
    test::write_text(file, text);
    expect_scene_error(dir / "s", {"scene.json"});
  }
  {
    json j = good;
    j["cameras"][0]["width"] = 0;
    write_json(file, j);
    expect_scene_error(dir / "s", {"cameras[0].width", "positive integer"});
  }
  {
    json j = good;
    j["fps"] = -3;
    write_json(file, j);
    expect_scene_error(dir / "s", {"fps", "> 0"});
  }
  {
    json j = good;
    j["format"] = "something-else";
    write_json(file, j);
    expect_scene_error(dir / "s", {"format"});
  }
  {
    json j = good;
    j["cameras"][1]["name"] = "cam00";
    write_json(file, j);
    expect_scene_error(dir / "s", {"cam00", "twice"});
  }
  {
    json j = good;
    j["cameras"][0]["split"] = "val";
    write_json(file, j);
    expect_scene_error(dir / "s", {"cameras[0].split"});
  }
  {
    json j = good;
    j["unknown_key"] = {1, 2, 3};  // unknown keys are ignored
    write_json(file, j);
    EXPECT_NO_THROW(read_scene(dir / "s"));
  }
}

// Finite but absurd values (core/limits.hpp), refused where scene.json is read, naming the key:
// unchecked, a 100000x100000 camera ends in std::bad_alloc and fx = 1e308 in NaNs.
TEST(Scene, ValuesBeyondTheirLimitsNameTheKey) {
  test::TempDir dir;
  write_small_scene(dir / "s");
  const json good = read_json(dir / "s" / "scene.json");
  const fs::path file = dir / "s" / "scene.json";
  const auto refused = [&](const std::function<void(json&)>& edit,
                           std::initializer_list<std::string> parts) {
    json j = good;
    edit(j);
    write_json(file, j);
    expect_scene_error(dir / "s", parts);
  };
  refused([](json& j) { j["cameras"][0]["width"] = 100000; },
          {"'cameras[0].width' = 100000", "16384"});
  refused([](json& j) { j["cameras"][1]["height"] = 16385; }, {"'cameras[1].height' = 16385"});
  refused([](json& j) { j["cameras"][0]["fx"] = 1e308; }, {"'cameras[0].fx' = 1e+308"});
  refused([](json& j) { j["cameras"][0]["fy"] = 1e-300; }, {"'cameras[0].fy' = 1e-300"});
  refused([](json& j) { j["cameras"][1]["world_to_camera"][2][3] = 1e308; },
          {"'cameras[1].world_to_camera[2][3]' = 1e+308", "beyond"});
  refused([](json& j) { j["fps"] = 1e-300; }, {"'fps' = 1e-300"});
  refused([](json& j) { j["fps"] = 1e9; }, {"'fps' = 1000000000"});
  refused([](json& j) { j["num_frames"] = 200000; }, {"'num_frames' = 200000", "100000"});
}

TEST(Scene, NonRigidMatrix) {
  test::TempDir dir;
  write_small_scene(dir / "s");
  json j = read_json(dir / "s" / "scene.json");
  j["cameras"][1]["world_to_camera"][0][0] = 2.0;
  write_json(dir / "s" / "scene.json", j);
  expect_scene_error(dir / "s", {"cameras[1].world_to_camera", "orthonormal"});
  j["cameras"][1]["world_to_camera"] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  write_json(dir / "s" / "scene.json", j);
  expect_scene_error(dir / "s", {"cameras[1].world_to_camera", "4x4"});
}

TEST(Scene, ImageSizeMismatchAndMissingImage) {
  test::TempDir dir;
  const Scene scene = write_small_scene(dir / "s");
  write_png(scene.image_path(1, 2), Image(13, 8, 3));
  expect_scene_error(dir / "s", {"images/7/00002.png", "12x8", "13x8"});
  write_png(scene.image_path(1, 2), Image(12, 8, 3));
  write_png(scene.mask_path(0, 1), Image(12, 9, 1));
  expect_scene_error(dir / "s", {"masks/cam00/00001.png", "12x9"});
  write_png(scene.mask_path(0, 1), Image(12, 8, 1));
  fs::remove(scene.image_path(0, 2));
  expect_scene_error(dir / "s", {"images/cam00/00002.png", "missing"});
}

TEST(Scene, FrameCountMustMatchImages) {
  test::TempDir dir;
  write_small_scene(dir / "s");
  json j = read_json(dir / "s" / "scene.json");
  j["num_frames"] = 4;
  write_json(dir / "s" / "scene.json", j);
  expect_scene_error(dir / "s", {"00003.png", "num_frames is 4"});
}

TEST(Scene, FlowOfWrongSizeIsRefused) {
  test::TempDir dir;
  const Scene scene = write_small_scene(dir / "s");
  write_flo(scene.flow_path(0, 1, 2), Flow(8, 8));
  try {
    load_flow(scene, 0, 1, 2);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("00001_00002.flo"), std::string::npos) << e.what();
  }
}

// The command line: one line on stderr naming the file, exit status 2, no output file.
TEST(SceneCli, BadSceneExitsTwoWithOneLine) {
  test::TempDir dir;
  const Scene scene = write_small_scene(dir / "s");
  const auto ok = test::run_cli("sheet --scene " + (dir / "s").string() + " --out " +
                                (dir / "sheet.png").string());
  ASSERT_EQ(ok.status, 0) << ok.err;
  EXPECT_TRUE(fs::exists(dir / "sheet.png"));

  // Truncated .flo read by the command.
  const std::string flo = test::read_text(scene.flow_path(0, 0, 1));
  test::write_text(scene.flow_path(0, 0, 1), flo.substr(0, flo.size() / 2));
  auto bad = test::run_cli("sheet --scene " + (dir / "s").string() + " --out " +
                           (dir / "sheet2.png").string());
  EXPECT_EQ(bad.status, 2);
  EXPECT_NE(bad.err.find("00000_00001.flo"), std::string::npos) << bad.err;
  EXPECT_EQ(std::count(bad.err.begin(), bad.err.end(), '\n'), 1) << bad.err;
  EXPECT_FALSE(fs::exists(dir / "sheet2.png"));

  test::write_text(dir / "s" / "scene.json", "not json");
  bad = test::run_cli("sheet --scene " + (dir / "s").string() + " --out " +
                      (dir / "sheet3.png").string());
  EXPECT_EQ(bad.status, 2);
  EXPECT_NE(bad.err.find("scene.json"), std::string::npos) << bad.err;
  EXPECT_EQ(std::count(bad.err.begin(), bad.err.end(), '\n'), 1) << bad.err;
  EXPECT_FALSE(fs::exists(dir / "sheet3.png"));

  bad = test::run_cli("sheet --scene " + (dir / "missing").string() + " --out x.png");
  EXPECT_EQ(bad.status, 2);
  EXPECT_NE(bad.err.find("missing"), std::string::npos) << bad.err;
}

}  // namespace
}  // namespace retimegs::io

namespace retimegs::io {
namespace {

TEST(SceneClocks, WrittenReadAndTimed) {
  test::TempDir dir;
  Scene scene = write_small_scene(dir / "s");      // 2 cameras, 3 frames
  EXPECT_DOUBLE_EQ(frame_time(scene, 1, 2), 2.0);  // no clocks: t = k
  EXPECT_FALSE(has_own_clocks(scene));
  scene.clocks = {{0.5, {}}, {-0.25, {0.0, 1.5, 4.0}}};
  write_scene_json(scene);
  const json j = read_json(scene.json_path());
  EXPECT_EQ(j["cameras"][0]["time_offset"], 0.5);
  EXPECT_FALSE(j["cameras"][0].contains("frame_times"));
  EXPECT_EQ(j["cameras"][1]["frame_times"], json::array({0.0, 1.5, 4.0}));
  const Scene read = read_scene_json(dir / "s");
  ASSERT_EQ(read.clocks.size(), 2u);
  EXPECT_EQ(read.clocks[0].time_offset, 0.5);
  EXPECT_EQ(read.clocks[1].frame_times, (std::vector<double>{0.0, 1.5, 4.0}));
  // Frame k at k + offset; with frame times at frame_times[k] + offset, straight lines between
  // and beyond the frames.
  EXPECT_DOUBLE_EQ(frame_time(read, 0, 0), 0.5);
  EXPECT_DOUBLE_EQ(frame_time(read, 0, 2), 2.5);
  EXPECT_DOUBLE_EQ(frame_time(read, 0, 1.25), 1.75);
  EXPECT_DOUBLE_EQ(frame_time(read, 1, 0), -0.25);
  EXPECT_DOUBLE_EQ(frame_time(read, 1, 1), 1.25);
  EXPECT_DOUBLE_EQ(frame_time(read, 1, 1.5), 2.5);   // halfway between 1.5 and 4.0, - 0.25
  EXPECT_DOUBLE_EQ(frame_time(read, 1, 3), 6.25);    // beyond: slope 2.5
  EXPECT_DOUBLE_EQ(frame_time(read, 1, -1), -1.75);  // before: slope 1.5
  // A genlocked scene's file carries no clock keys, and reads back without clocks.
  scene.clocks = {{}, {}};
  write_scene_json(scene);
  EXPECT_FALSE(read_json(scene.json_path())["cameras"][0].contains("time_offset"));
  EXPECT_TRUE(read_scene_json(dir / "s").clocks.empty());
}

TEST(SceneClocks, BadClocksNameFileCameraAndKey) {
  test::TempDir dir;
  write_small_scene(dir / "s");
  const fs::path file = dir / "s" / "scene.json";
  const json good = read_json(file);
  const std::string camera = "'" + good["cameras"][1]["name"].get<std::string>() + "'";
  const auto expect = [&](const std::function<void(json&)>& edit,
                          std::initializer_list<std::string> fragments) {
    json j = good;
    edit(j);
    write_json(file, j);
    std::vector<std::string> all = {"scene.json", camera};
    all.insert(all.end(), fragments.begin(), fragments.end());
    try {
      read_scene_json(dir / "s");
      ADD_FAILURE() << "no error for " << j["cameras"][1].dump();
    } catch (const Error& e) {
      for (const auto& f : all)
        EXPECT_NE(std::string(e.what()).find(f), std::string::npos) << e.what();
    }
  };
  expect([](json& j) { j["cameras"][1]["time_offset"] = "half"; }, {"time_offset", "number"});
  expect([](json& j) { j["cameras"][1]["time_offset"] = nullptr; }, {"time_offset"});
  expect([](json& j) { j["cameras"][1]["frame_times"] = {0.0, 1.0}; }, {"frame_times", "2 values"});
  expect(
      [](json& j) {
        j["cameras"][1]["frame_times"] = {0.0, 1.0, 1.0};
      },
      {"frame_times", "increase"});
  expect(
      [](json& j) {
        j["cameras"][1]["frame_times"] = {0.0, 2.0, 1.0};
      },
      {"frame_times", "increase"});
  expect([](json& j) { j["cameras"][1]["frame_times"] = 3; }, {"frame_times", "array"});
  expect([](json& j) { j["cameras"][1]["frame_times"] = {0.0, nullptr, 2.0}; }, {"frame_times[1]"});
  {
    // Overflow to infinity: the one way a non-finite number reaches the file.
    json j = good;
    j["cameras"][1]["time_offset"] = 123.0;
    std::string text = j.dump();
    text.replace(text.find("123.0"), 5, "1e999");
    test::write_text(file, text);
    try {
      read_scene_json(dir / "s");
      ADD_FAILURE() << "no error";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("scene.json"), std::string::npos) << e.what();
    }
  }
  // write_scene_json refuses what reading would.
  write_json(file, good);
  Scene scene = read_scene_json(dir / "s");
  scene.clocks = {{}, {std::nan(""), {}}};
  try {
    write_scene_json(scene);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    for (const std::string f : {std::string("scene.json"), camera, std::string("not finite")})
      EXPECT_NE(std::string(e.what()).find(f), std::string::npos) << e.what();
  }
  scene.clocks = {{}, {0, {0.0, 1.0}}};
  EXPECT_THROW(write_scene_json(scene), Error);
}

}  // namespace
}  // namespace retimegs::io

namespace retimegs::io {
namespace {

TEST(SceneCalibration, WrittenAndReadBackLabWhenAbsent) {
  test::TempDir dir;
  Scene scene = write_small_scene(dir / "s");
  EXPECT_EQ(read_json(scene.json_path())["calibration"], "lab");  // the default, written out
  scene.calibration = CalibrationSource::kUser;
  write_scene_json(scene);
  EXPECT_EQ(read_json(scene.json_path())["calibration"], "user");
  EXPECT_EQ(read_scene_json(dir / "s").calibration, CalibrationSource::kUser);
  // A scene written before the key existed: a dataset's calibration, taken as exact.
  json j = read_json(scene.json_path());
  j.erase("calibration");
  write_json(scene.json_path(), j);
  EXPECT_EQ(read_scene_json(dir / "s").calibration, CalibrationSource::kLab);
  j["calibration"] = "lab";
  write_json(scene.json_path(), j);
  EXPECT_EQ(read_scene_json(dir / "s").calibration, CalibrationSource::kLab);
}

TEST(SceneCalibration, UnknownValueNamesFileFieldAndValue) {
  test::TempDir dir;
  const Scene scene = write_small_scene(dir / "s");
  json j = read_json(scene.json_path());
  j["calibration"] = "checkerboard";
  write_json(scene.json_path(), j);
  try {
    read_scene_json(dir / "s");
    FAIL() << "no error";
  } catch (const Error& e) {
    for (const std::string f : {"scene.json", "'calibration'", "\"checkerboard\"", "\"user\""})
      EXPECT_NE(std::string(e.what()).find(f), std::string::npos) << e.what();
  }
  j["calibration"] = 1;
  write_json(scene.json_path(), j);
  try {
    read_scene_json(dir / "s");
    FAIL() << "no error";
  } catch (const Error& e) {
    for (const std::string f : {"scene.json", "'calibration'", "string"})
      EXPECT_NE(std::string(e.what()).find(f), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace retimegs::io

namespace retimegs::io {
namespace {

TEST(SceneClockSource, EstimatedWrittenGivenWhenAbsent) {
  test::TempDir dir;
  Scene scene = write_small_scene(dir / "s");
  EXPECT_FALSE(read_json(scene.json_path()).contains("clocks"));  // given: the file unchanged
  EXPECT_EQ(read_scene_json(dir / "s").clock_source, ClockSource::kGiven);
  scene.clock_source = ClockSource::kEstimated;
  write_scene_json(scene);
  EXPECT_EQ(read_json(scene.json_path())["clocks"], "estimated");
  EXPECT_EQ(read_scene_json(dir / "s").clock_source, ClockSource::kEstimated);
  json j = read_json(scene.json_path());
  j["clocks"] = "given";
  write_json(scene.json_path(), j);
  EXPECT_EQ(read_scene_json(dir / "s").clock_source, ClockSource::kGiven);
  j["clocks"] = "genlocked";
  write_json(scene.json_path(), j);
  try {
    read_scene_json(dir / "s");
    FAIL() << "no error";
  } catch (const Error& e) {
    for (const std::string f : {"scene.json", "'clocks'", "\"genlocked\"", "\"estimated\""})
      EXPECT_NE(std::string(e.what()).find(f), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace retimegs::io
