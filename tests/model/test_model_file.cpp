#include <sys/stat.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/model/model_file.hpp"
#include "test_util.hpp"

namespace retimegs::model {
namespace {
namespace fs = std::filesystem;

Model random_model(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> normal;
  Model m;
  m.primitives.resize(n);
  for (auto f : m.primitives.fields())
    for (float& v : *f.values) v = normal(rng);
  for (std::size_t i = 0; i < n; ++i) m.primitives.tau_l[i] = m.primitives.tau_r[i] = 1.0f + i;
  m.grid = {0.0, 2.0, 9};
  m.config.representation = Representation::kStgs;
  m.config.trajectory = TrajectoryKind::kLinear;
  m.config.gamma = 0.007;
  m.config.sh_degree = 2;
  m.training_config = R"({"iters":1234,"ablate":["no-stretch"]})";
  return m;
}

void expect_refused(const fs::path& path, const std::string& fragment) {
  try {
    read_model(path);
    FAIL() << "accepted " << path;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(ModelFile, RoundTripIsExact) {
  test::TempDir dir;
  const Model m = random_model(37, 1);
  write_model(dir / "m.rgs", m);
  const Model r = read_model(dir / "m.rgs");
  const auto a = m.primitives.fields(), b = r.primitives.fields();
  for (int i = 0; i < Primitives::kFieldCount; ++i)
    EXPECT_EQ(*a[i].values, *b[i].values) << a[i].name;
  EXPECT_EQ(r.grid.first, 0.0);
  EXPECT_EQ(r.grid.step, 2.0);
  EXPECT_EQ(r.grid.count, 9);
  EXPECT_EQ(r.config.representation, Representation::kStgs);
  EXPECT_EQ(r.config.trajectory, TrajectoryKind::kLinear);
  EXPECT_EQ(r.config.gamma, 0.007);
  EXPECT_EQ(r.config.sh_degree, 2);
  EXPECT_EQ(r.training_config, R"({"ablate":["no-stretch"],"iters":1234})");
  // Only the model file is left in the folder (the temporary was renamed).
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 1);
}

TEST(ModelFile, EmptyModelRoundTrips) {
  test::TempDir dir;
  write_model(dir / "e.rgs", random_model(0, 2));
  EXPECT_EQ(read_model(dir / "e.rgs").primitives.size(), 0u);
}

TEST(ModelFile, TruncatedOrCorruptedFilesAreRefused) {
  test::TempDir dir;
  write_model(dir / "m.rgs", random_model(20, 3));
  const std::string bytes = test::read_text(dir / "m.rgs");
  // Cut anywhere: inside the prefix, the header, the data, the checksum.
  for (std::size_t keep : {std::size_t(5), std::size_t(14), std::size_t(60), bytes.size() / 2,
                           bytes.size() - 9, bytes.size() - 1}) {
    test::write_text(dir / "cut.rgs", bytes.substr(0, keep));
    EXPECT_THROW(read_model(dir / "cut.rgs"), Error) << "kept " << keep << " bytes";
  }
  test::write_text(dir / "cut.rgs", bytes.substr(0, bytes.size() - 400));
  expect_refused(dir / "cut.rgs", "truncated");
  // One flipped bit in the data.
  std::string flipped = bytes;
  flipped[bytes.size() - 100] ^= 0x10;
  test::write_text(dir / "flip.rgs", flipped);
  expect_refused(dir / "flip.rgs", "checksum");
  // Wrong magic, future version.
  std::string magic = bytes;
  magic[0] = 'X';
  test::write_text(dir / "magic.rgs", magic);
  expect_refused(dir / "magic.rgs", "not a retimegs model");
  std::string version = bytes;
  version[8] = 9;
  test::write_text(dir / "version.rgs", version);
  expect_refused(dir / "version.rgs", "version 9");
  expect_refused(dir / "missing.rgs", "cannot open");
}

// The bytes of a model file `bytes` with its JSON header replaced by edit(header), the checksum
// recomputed (FNV-1a 64 over every preceding byte, as the format defines it).
template <typename Edit>
std::string with_header(const std::string& bytes, const Edit& edit) {
  std::uint32_t size = 0;
  std::memcpy(&size, bytes.data() + 12, 4);
  nlohmann::json header = nlohmann::json::parse(bytes.substr(16, size));
  edit(header);
  const std::string text = header.dump();
  const std::uint32_t new_size = std::uint32_t(text.size());
  std::string out = bytes.substr(0, 12);
  out.append(reinterpret_cast<const char*>(&new_size), 4);
  out += text;
  out += bytes.substr(16 + size, bytes.size() - 16 - size - 8);
  std::uint64_t hash = 0xcbf29ce484222325ull;
  for (const char ch : out) hash = (hash ^ static_cast<unsigned char>(ch)) * 0x100000001b3ull;
  out.append(reinterpret_cast<const char*>(&hash), 8);
  return out;
}

// Edited headers (issue 26; fuzz/corpus/rgs): a count or a number that the file cannot back is
// refused with the key and value named, before anything is allocated for it (a count of 10^9
// allocated 3 GB before saying "truncated").
TEST(ModelFile, EditedHeadersAreRefusedNamingTheValue) {
  test::TempDir dir;
  write_model(dir / "m.rgs", random_model(4, 8));
  const std::string bytes = test::read_text(dir / "m.rgs");
  struct Case {
    const char* name;
    std::function<void(nlohmann::json&)> edit;
    const char* fragment;
  };
  const Case cases[] = {
      {"count_1e9", [](auto& h) { h["count"] = 1'000'000'000; }, "header count 1000000000"},
      {"count_2e18", [](auto& h) { h["count"] = 2'000'000'000'000'000'000ull; },
       "header count 2000000000000000000"},
      {"count_1e19", [](auto& h) { h["count"] = 10'000'000'000'000'000'000ull; },
       "'count' must be an integer"},
      {"count_negative", [](auto& h) { h["count"] = -1; }, "'count' must be an integer"},
      {"count_float", [](auto& h) { h["count"] = 4.5; }, "'count' must be an integer"},
      {"count_5", [](auto& h) { h["count"] = 5; }, "header count 5"},
      {"grid_count_1e20", [](auto& h) { h["time_grid"]["count"] = 1e20; },
       "'time_grid.count' must be an integer"},
      // A clip's frame limit (core/limits.hpp): the viewer's pack lists every training frame.
      {"grid_count_1e9", [](auto& h) { h["time_grid"]["count"] = 1'000'000'000; },
       "'time_grid.count' must be an integer in [1, 100000], got 1000000000"},
      {"step_string", [](auto& h) { h["time_grid"]["step"] = "1"; },
       "'time_grid.step' must be a finite number"},
      {"sh_degree_9", [](auto& h) { h["model"]["sh_degree"] = 9; }, "'model.sh_degree'"},
      {"fields_object",
       [](auto& h) {
         h["fields"] = {{"name", "mu"}};
       },
       "'fields' is not an array"},
      {"fields_numbers",
       [](auto& h) {
         h["fields"] = {1, 2};
       },
       "lacks field 'mu'"},
      {"offset_negative", [](auto& h) { h["fields"][0]["offset"] = -8; }, "unexpected layout"},
      {"offset_past_end", [](auto& h) { h["fields"][0]["offset"] = 1u << 30; },
       "unexpected layout"},
      {"header_array", [](auto& h) { h = nlohmann::json::array(); }, "not a JSON object"},
      {"seam_off_grid", [](auto& h) { h["seams"] = {3.0}; }, "seam 3 is not a training frame"},
      {"seam_at_end", [](auto& h) { h["seams"] = {16.0}; }, "interior"},
      {"seams_descending",
       [](auto& h) {
         h["seams"] = {8.0, 4.0};
       },
       "ascending"},
  };
  for (const Case& c : cases) {
    const fs::path path = dir / (std::string(c.name) + ".rgs");
    test::write_text(path, with_header(bytes, c.edit));
    SCOPED_TRACE(c.name);
    expect_refused(path, c.fragment);
  }
}

TEST(ModelFile, CameraColorsRoundTripByCameraName) {
  test::TempDir dir;
  Model m = random_model(5, 5);
  m.camera_colors["cam00"] = {{0.1f, -0.25f, 1e-7f}, {0.03f, 0.0f, -0.3333333f}};
  m.camera_colors["17"] = {{-0.5f, 0.5f, 0.2f}, {0.01f, 0.02f, 0.03f}};
  write_model(dir / "m.rgs", m);
  const Model r = read_model(dir / "m.rgs");
  ASSERT_EQ(r.camera_colors.size(), 2u);
  for (const auto& [camera, color] : m.camera_colors) {
    const CameraColor* read = find_camera_color(r, camera);
    ASSERT_NE(read, nullptr) << camera;
    EXPECT_EQ(read->m, color.m) << camera;
    EXPECT_EQ(read->c, color.c) << camera;
  }
  EXPECT_EQ(find_camera_color(r, "cam01"), nullptr);
}

// A model without corrections is written as earlier builds wrote every model (no
// "camera_colors" key), and such a file loads with none.
TEST(ModelFile, FilesWithoutCameraColorsLoadWithNone) {
  test::TempDir dir;
  Model m = random_model(6, 6);
  m.camera_colors["cam00"].m = {0.1f, 0.2f, 0.3f};
  write_model(dir / "with.rgs", m);
  test::write_text(dir / "old.rgs", with_header(test::read_text(dir / "with.rgs"),
                                                [](auto& h) { h.erase("camera_colors"); }));
  const Model old = read_model(dir / "old.rgs");
  EXPECT_TRUE(old.camera_colors.empty());
  EXPECT_EQ(old.primitives.mu, m.primitives.mu);
  m.camera_colors.clear();
  write_model(dir / "none.rgs", m);
  EXPECT_EQ(test::read_text(dir / "none.rgs"), test::read_text(dir / "old.rgs"));
}

TEST(ModelFile, MalformedCameraColorsAreRefused) {
  test::TempDir dir;
  Model m = random_model(3, 7);
  m.camera_colors["cam03"] = {};
  write_model(dir / "m.rgs", m);
  const std::string bytes = test::read_text(dir / "m.rgs");
  test::write_text(dir / "short.rgs", with_header(bytes, [](auto& h) {
                     h["camera_colors"]["cam03"]["m"] = {0.0, 1.0};
                   }));
  expect_refused(dir / "short.rgs", "camera colour of 'cam03' lacks 'm'");
  test::write_text(dir / "null.rgs", with_header(bytes, [](auto& h) {
                     h["camera_colors"]["cam03"]["c"][1] = nullptr;
                   }));
  expect_refused(dir / "null.rgs", "camera colour 'c' of 'cam03' is not finite");
  m.camera_colors["cam03"].c[2] = std::numeric_limits<float>::infinity();
  test::expect_error([&] { write_model(dir / "inf.rgs", m); },
                     {"inf.rgs", "camera colour of 'cam03' is not finite"});
  EXPECT_FALSE(fs::exists(dir / "inf.rgs"));
}

// Issue 65: each refined training camera's pose correction, by name, to the last bit.
TEST(ModelFile, CameraPosesRoundTripByCameraName) {
  test::TempDir dir;
  Model m = random_model(5, 8);
  m.camera_poses["cam00"] = {{0.01, -0.0123456789012345, 3e-9}, {0.25, -1.0 / 3, 1e-12}};
  m.camera_poses["17"] = {{-1.5, 2.5, 0.1}, {0, 0, -7.0}};  // |ω| = 2.92 rad
  write_model(dir / "m.rgs", m);
  const Model r = read_model(dir / "m.rgs");
  ASSERT_EQ(r.camera_poses.size(), 2u);
  for (const auto& [camera, pose] : m.camera_poses) {
    const CameraPose* read = find_camera_pose(r, camera);
    ASSERT_NE(read, nullptr) << camera;
    EXPECT_EQ(read->rotation, pose.rotation) << camera;
    EXPECT_EQ(read->translation, pose.translation) << camera;
  }
  EXPECT_EQ(find_camera_pose(r, "cam01"), nullptr);
  EXPECT_TRUE(r.camera_colors.empty());
}

// A model without pose corrections is written as earlier builds wrote every model (no
// "camera_poses" key), and such a file loads with none.
TEST(ModelFile, FilesWithoutCameraPosesLoadWithNone) {
  test::TempDir dir;
  Model m = random_model(6, 9);
  m.camera_poses["cam00"] = {{0.01, 0.02, 0.03}, {0.1, 0.2, 0.3}};
  write_model(dir / "with.rgs", m);
  test::write_text(dir / "old.rgs", with_header(test::read_text(dir / "with.rgs"),
                                                [](auto& h) { h.erase("camera_poses"); }));
  const Model old = read_model(dir / "old.rgs");
  EXPECT_TRUE(old.camera_poses.empty());
  EXPECT_EQ(old.primitives.mu, m.primitives.mu);
  m.camera_poses.clear();
  write_model(dir / "none.rgs", m);
  EXPECT_EQ(test::read_text(dir / "none.rgs"), test::read_text(dir / "old.rgs"));
}

TEST(ModelFile, MalformedCameraPosesAreRefused) {
  test::TempDir dir;
  Model m = random_model(3, 10);
  m.camera_poses["cam03"] = {{0.01, 0, 0}, {0, 0, 0.1}};
  write_model(dir / "m.rgs", m);
  const std::string bytes = test::read_text(dir / "m.rgs");
  using nlohmann::json;
  struct Case {
    const char* name;
    std::function<void(json&)> edit;
    std::string fragment;
  };
  const std::vector<Case> cases = {
      {"table", [](json& h) { h["camera_poses"] = json::array(); },
       "'camera_poses' is not an object"},
      {"entry", [](json& h) { h["camera_poses"]["cam03"] = 1.0; },
       "camera pose of 'cam03' lacks 'rotation' as 3 numbers"},
      {"short",
       [](json& h) {
         h["camera_poses"]["cam03"]["translation"] = {0.0, 1.0};
       },
       "camera pose of 'cam03' lacks 'translation' as 3 numbers"},
      {"missing", [](json& h) { h["camera_poses"]["cam03"].erase("rotation"); },
       "camera pose of 'cam03' lacks 'rotation'"},
      {"null", [](json& h) { h["camera_poses"]["cam03"]["rotation"][1] = nullptr; },
       "camera pose 'rotation' of 'cam03' is not finite"},
      {"text", [](json& h) { h["camera_poses"]["cam03"]["translation"][0] = "0.1"; },
       "camera pose 'translation' of 'cam03' is not finite"},
      // pi itself is refused: the same turn as -pi about the axis, two values for one rotation.
      {"pi",
       [](json& h) {
         h["camera_poses"]["cam03"]["rotation"] = {0.0, 0.0, -std::numbers::pi};
       },
       "camera pose of 'cam03' turns by 3.14159"},
      {"turn",
       [](json& h) {
         h["camera_poses"]["cam03"]["rotation"] = {2.0, 2.0, 2.0};
       },
       "not less than pi"},
  };
  for (const Case& c : cases) {
    const fs::path path = dir / (std::string(c.name) + ".rgs");
    test::write_text(path, with_header(bytes, c.edit));
    SCOPED_TRACE(c.name);
    expect_refused(path, c.fragment);
  }
  // Just below pi is a rotation like any other.
  test::write_text(dir / "below.rgs", with_header(bytes, [](json& h) {
                     h["camera_poses"]["cam03"]["rotation"] = {0.0, 0.0, 3.1415};
                   }));
  EXPECT_EQ(read_model(dir / "below.rgs").camera_poses.at("cam03").rotation[2], 3.1415);
  m.camera_poses["cam03"].translation[2] = std::numeric_limits<double>::infinity();
  test::expect_error([&] { write_model(dir / "inf.rgs", m); },
                     {"inf.rgs", "camera pose of 'cam03' is not finite"});
  m.camera_poses["cam03"] = {{4.0, 0, 0}, {}};
  test::expect_error([&] { write_model(dir / "wide.rgs", m); },
                     {"wide.rgs", "camera pose of 'cam03' turns by 4"});
  EXPECT_FALSE(fs::exists(dir / "inf.rgs"));
  EXPECT_FALSE(fs::exists(dir / "wide.rgs"));
}

// seen_camera: a refined camera through its correction, any other camera as it is.
TEST(ModelFile, SeenCameraCorrectsTheRefinedCamerasOnly) {
  Model m = random_model(1, 11);
  const CameraPose pose{{0.02, -0.01, 0.005}, {0.1, 0.0, -0.05}};
  m.camera_poses["cam00"] = pose;
  Camera cam;
  cam.name = "cam00";
  cam.world_to_camera(0, 3) = 1.0;
  cam.world_to_camera(2, 3) = 4.0;
  const Camera seen = seen_camera(m, cam);
  EXPECT_EQ(seen.world_to_camera, corrected(cam, pose).world_to_camera);
  EXPECT_GT((seen.world_to_camera - cam.world_to_camera).norm(), 0.05);
  EXPECT_EQ(seen.name, "cam00");
  Camera other = cam;
  other.name = "cam01";
  EXPECT_EQ(seen_camera(m, other).world_to_camera, cam.world_to_camera);
}

TEST(ModelFile, NonFiniteParametersAreNotWritten) {
  test::TempDir dir;
  Model m = random_model(4, 4);
  m.primitives.velocity[13] = std::numeric_limits<float>::quiet_NaN();
  try {
    write_model(dir / "nan.rgs", m);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("velocity"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("primitive 1"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "nan.rgs"));
}

// read_model refuses a FIFO itself (opening one would block until a writer came) and a folder.
TEST(ModelFile, FifoAndFolderAreRefusedNamingThePath) {
  test::TempDir dir;
  const fs::path fifo = dir / "model.fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  const std::string on_fifo = test::message_of([&] { read_model(fifo); });
  EXPECT_NE(on_fifo.find(fifo.string() + ": is a FIFO"), std::string::npos) << on_fifo;
  const std::string on_folder = test::message_of([&] { read_model(dir.path()); });
  EXPECT_NE(on_folder.find("is a folder"), std::string::npos) << on_folder;
}

}  // namespace
}  // namespace retimegs::model
