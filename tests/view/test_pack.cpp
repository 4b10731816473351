// The viewer's data (view/pack.hpp, view/web.hpp) against the .rgs values it was packed from.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <fstream>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli/cli_run.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/view/pack.hpp"
#include "retimegs/view/web.hpp"
#include "test_util.hpp"
#include "view_fixture.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;

// The packed model read back from the .rgs file, as `retimegs view` packs it.
struct PackedFixture {
  test::TempDir dir;
  model::Model model;
  io::Scene scene;
  view::Packed packed;
  json manifest;

  explicit PackedFixture(std::size_t count = 301) {
    model::write_model(dir / "model.rgs", test::view_fixture_model(count, 3));
    model = model::read_model(dir / "model.rgs");
    scene = test::view_fixture_scene(dir / "scene");
    packed = view::pack(model, {&scene, io::scene_near_plane(scene)});
    manifest = json::parse(packed.manifest);
  }

  const json& texture(const std::string& name) const {
    for (const json& t : manifest["textures"])
      if (t["name"] == name) return t;
    throw Error("no texture " + name);
  }
  // Component c of texel k of primitive i.
  float value(const std::string& name, std::size_t i, int k, int c) const {
    const json& t = texture(name);
    const std::size_t at = (i * t["texels_per_primitive"].get<std::size_t>() + k) * 4 + c;
    const std::uint8_t* base = packed.data.data() + t["offset"].get<std::size_t>();
    if (t["type"] == "rgba32f") {
      float f;
      std::memcpy(&f, base + 4 * at, 4);
      return f;
    }
    std::uint16_t h;
    std::memcpy(&h, base + 2 * at, 2);
    return view::float_from_half(h);
  }
};

// A half float holds 11 significant bits: round to nearest is within 2^-11 relative (and the
// subnormal step 2^-24 absolute).
void expect_half_of(float packed, float original, const std::string& what) {
  EXPECT_LE(std::abs(packed - original),
            std::ldexp(std::abs(original), -11) + std::ldexp(1.0f, -25))
      << what << ": " << original << " packed as " << packed;
}

TEST(ViewPack, PositionsAndTimesAreTheModelsFloat32Values) {
  const PackedFixture f;
  const model::Primitives& p = f.model.primitives;
  for (std::size_t i = 0; i < p.size(); ++i) {
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(f.value("mu", i, 0, a), p.mu[3 * i + a]) << i;
      for (int j = 0; j < 3; ++j)
        EXPECT_EQ(f.value("v" + std::to_string(j + 1), i, 0, a), p.velocity[9 * i + 3 * j + a]);
    }
    EXPECT_EQ(f.value("mu", i, 0, 3), p.mu_tau[i]);
    EXPECT_EQ(f.value("v1", i, 0, 3), p.tau_l[i]);
    EXPECT_EQ(f.value("v2", i, 0, 3), p.tau_r[i]);
    EXPECT_EQ(f.value("v3", i, 0, 3), p.temporal_log_scale[i]);
  }
}

TEST(ViewPack, ShapeRotationAndShAreHalfFloatsOfTheModelsValues) {
  const PackedFixture f;
  const model::Primitives& p = f.model.primitives;
  constexpr int kSh = model::Primitives::kShWidth;
  EXPECT_EQ(f.texture("sh")["texels_per_primitive"], 12);  // degree 3: 48 values
  for (std::size_t i = 0; i < p.size(); ++i) {
    for (int a = 0; a < 3; ++a)
      expect_half_of(f.value("shape", i, 0, a), p.log_scale[3 * i + a], "log_scale");
    expect_half_of(f.value("shape", i, 0, 3), p.opacity_logit[i], "opacity_logit");
    for (int a = 0; a < 4; ++a) {
      expect_half_of(f.value("q0", i, 0, a), p.q0[4 * i + a], "q0");
      expect_half_of(f.value("q1", i, 0, a), p.q1[4 * i + a], "q1");
    }
    for (int k = 0; k < kSh; ++k)
      expect_half_of(f.value("sh", i, k / 4, k % 4), p.sh[kSh * i + k], "sh");
  }
}

TEST(ViewPack, TexturesAreWholeRowsOneAfterAnother) {
  const PackedFixture f(5000);  // 5000 primitives: 3 rows of 2048, the SH 30 rows
  std::uint64_t offset = 0;
  for (const json& t : f.manifest["textures"]) {
    const std::uint64_t texels = 5000 * t["texels_per_primitive"].get<std::uint64_t>();
    const std::uint64_t rows = (texels + view::kTextureWidth - 1) / view::kTextureWidth;
    EXPECT_EQ(t["height"].get<std::uint64_t>(), rows) << t["name"];
    EXPECT_EQ(t["offset"].get<std::uint64_t>(), offset) << t["name"];
    const int bytes_per_value = t["type"] == "rgba16f" ? 2 : 4;
    EXPECT_EQ(t["bytes"].get<std::uint64_t>(), rows * view::kTextureWidth * 4 * bytes_per_value);
    // The padding after the last primitive is zero.
    const std::uint8_t* end = f.packed.data.data() + offset + texels * 4 * bytes_per_value;
    const std::uint8_t* stop = f.packed.data.data() + offset + t["bytes"].get<std::uint64_t>();
    EXPECT_TRUE(std::all_of(end, stop, [](std::uint8_t b) { return b == 0; })) << t["name"];
    offset += t["bytes"].get<std::uint64_t>();
  }
  EXPECT_EQ(offset, f.packed.data.size());
}

TEST(ViewPack, ManifestCarriesEvaluatesSettingsAndTheScene) {
  const PackedFixture f;
  const json& m = f.manifest;
  EXPECT_EQ(m["count"], 301);
  EXPECT_EQ(m["representation"], "retime");
  EXPECT_EQ(m["trajectory"], "catmull_rom");
  EXPECT_EQ(m["time"]["first"], 0.0);
  EXPECT_EQ(m["time"]["step"], 2.0);
  EXPECT_EQ(m["time"]["last"], 8.0);
  EXPECT_EQ(m["training_frames"], json({0.0, 2.0, 4.0, 6.0, 8.0}));
  EXPECT_DOUBLE_EQ(m["gamma_frames"].get<double>(), 0.02 * 8);
  EXPECT_DOUBLE_EQ(m["epsilon"].get<double>(), f.model.config.epsilon);
  EXPECT_EQ(m["handover_tail"].get<double>(), model::kHandoverTail);
  EXPECT_EQ(m["sh_degree"], 3);
  EXPECT_DOUBLE_EQ(m["near"].get<double>(), io::scene_near_plane(f.scene));
  EXPECT_EQ(m["up"], json({0.0, -1.0, 0.0}));
  ASSERT_EQ(m["cameras"].size(), 2u);
  const json& cam0 = m["cameras"][0];
  EXPECT_EQ(cam0["name"], "cam0");
  EXPECT_EQ(cam0["width"], 160);
  EXPECT_EQ(cam0["split"], "train");
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      EXPECT_EQ(cam0["world_to_camera"][4 * r + c].get<double>(),
                f.scene.cameras[0].world_to_camera(r, c));
  const model::CameraColor& color = f.model.camera_colors.at("cam0");
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(cam0["color"]["m"][k].get<float>(), color.m[k]);
    EXPECT_EQ(cam0["color"]["c"][k].get<float>(), color.c[k]);
  }
  EXPECT_FALSE(m["cameras"][1].contains("color"));  // no map: the model's own colours
}

// Issue 65: the viewer's cameras are the scene's as the model saw them, so that snapping to a
// training camera reproduces its frames as render --camera does.
TEST(ViewPack, CamerasAreSentThroughTheModelsPoseCorrections) {
  const PackedFixture f;
  model::Model m = f.model;
  const model::CameraPose pose{{0.01, -0.02, 0.03}, {0.05, 0.0, -0.1}};
  m.camera_poses["cam0"] = pose;
  view::PackScene scene;
  scene.scene = &f.scene;
  const json manifest = json::parse(view::pack(m, scene).manifest);
  const Eigen::Matrix4d seen = model::corrected(f.scene.cameras[0], pose).world_to_camera;
  ASSERT_GT((seen - f.scene.cameras[0].world_to_camera).norm(), 0.05);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) {
      EXPECT_EQ(manifest["cameras"][0]["world_to_camera"][4 * r + c].get<double>(), seen(r, c));
      EXPECT_EQ(manifest["cameras"][1]["world_to_camera"][4 * r + c].get<double>(),
                f.scene.cameras[1].world_to_camera(r, c));
    }
}

TEST(ViewPack, LowerShDegreePacksOnlyItsCoefficients) {
  model::Model m = test::view_fixture_model(10, 1);
  m.config.sh_degree = 1;  // 4 coefficients, 12 values: 3 texels
  const view::Packed packed = view::pack(m, {});
  const json manifest = json::parse(packed.manifest);
  EXPECT_EQ(manifest["sh_degree"], 1);
  EXPECT_EQ(manifest["cameras"].size(), 0u);
  for (const json& t : manifest["textures"])
    if (t["name"] == "sh") {
      EXPECT_EQ(t["texels_per_primitive"], 3);
    }
}

TEST(ViewPack, ValueBeyondHalfRangeIsRefusedNamingIt) {
  model::Model m = test::view_fixture_model(10, 1);
  m.primitives.sh[model::Primitives::kShWidth * 4 + 5] = 1e5f;
  try {
    view::pack(m, {});
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("sh of primitive 4"), std::string::npos) << e.what();
  }
}

TEST(ViewPack, HalfConversionRoundsToNearestEven) {
  // Every finite half converts to float and back to itself.
  for (std::uint32_t h = 0; h < 0x10000; ++h) {
    if ((h & 0x7c00) == 0x7c00) continue;  // infinities and NaNs
    ASSERT_EQ(view::half_from_float(view::float_from_half(std::uint16_t(h))), h) << h;
  }
  EXPECT_EQ(view::half_from_float(1.0f + std::ldexp(1.0f, -11)), 0x3c00);  // tie: to even
  EXPECT_EQ(view::half_from_float(1.0f + 3 * std::ldexp(1.0f, -11)), 0x3c02);
  EXPECT_EQ(view::half_from_float(65520.0f), 0x7c00);  // rounds past the largest: infinity
  EXPECT_EQ(view::half_from_float(std::ldexp(1.0f, -25)), 0x0000);  // tie below: to even 0
  EXPECT_EQ(view::half_from_float(std::ldexp(1.5f, -25)), 0x0001);
  EXPECT_EQ(view::half_from_float(-2.0f), 0xc000);
}

TEST(ViewPack, ForWebReadsAWindowModelAsTrainedWithTheScenesNearPlane) {
  test::TempDir dir;
  model::Model window = test::view_fixture_model(40, 4);
  window.window = model::TimeWindow{1, 3};  // training frames 2, 4, 6 of the clip's 0..8
  model::write_model(dir / "window.rgs", window);
  fs::create_directories(dir / "scene");
  const io::Scene scene = test::view_fixture_scene(dir / "scene");
  io::write_scene_json(scene);
  const json with_scene =
      json::parse(view::pack_for_web(dir / "window.rgs", dir / "scene", {}).manifest);
  EXPECT_EQ(with_scene["time"]["first"], 2.0);
  EXPECT_EQ(with_scene["time"]["last"], 6.0);
  EXPECT_DOUBLE_EQ(with_scene["near"].get<double>(), io::scene_near_plane(scene));
  EXPECT_EQ(with_scene["cameras"].size(), 2u);
  EXPECT_DOUBLE_EQ(
      json::parse(view::pack_for_web(dir / "window.rgs", dir / "scene", 0.5).manifest)["near"]
          .get<double>(),
      0.5);
  // Without a scene: no cameras; a near plane given is checked.
  const json alone = json::parse(view::pack_for_web(dir / "window.rgs", "", 0.25).manifest);
  EXPECT_DOUBLE_EQ(alone["near"].get<double>(), 0.25);
  EXPECT_TRUE(alone["cameras"].empty());
  test::expect_error([&] { view::pack_for_web(dir / "window.rgs", "", -1.0); }, {"--near"});
  test::expect_error([&] { view::pack_for_web(dir / "none.rgs", "", {}); }, {"none.rgs"});
}

TEST(ViewWeb, ExportWritesTheServedFilesByteForByte) {
  const PackedFixture f;
  const std::vector<view::WebFile> files = view::web_files(f.packed);
  for (const char* name :
       {"index.html", "main.js", "renderer.js", "sort_worker.js", "time_model.js", "model_data.js",
        "camera.js", "model.json", "model.bin"})
    EXPECT_TRUE(std::any_of(files.begin(), files.end(), [&](const view::WebFile& w) {
      return w.path == name;
    })) << name;
  view::write_web(f.dir / "site", files, false);
  for (const view::WebFile& w : files) {
    std::ifstream in(f.dir / "site" / w.path, std::ios::binary);
    std::stringstream content;
    content << in.rdbuf();
    EXPECT_EQ(content.str(), std::string(w.content)) << w.path;
  }
  EXPECT_THROW(view::write_web(f.dir / "site", files, false), Error);  // exists, no --force
  view::write_web(f.dir / "site", files, true);
}

TEST(ViewCli, MissingOrCorruptModelIsRefusedBeforeServing) {
  test::TempDir dir;
  auto r = test::run_cli("view --model " + (dir / "none.rgs").string() + " --port 0");
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(test::is_one_error_line(r.err)) << r.err;
  EXPECT_NE(r.err.find("none.rgs"), std::string::npos) << r.err;
  std::ofstream(dir / "bad.rgs") << "RETIMEGS but not a model";
  r = test::run_cli("view --model " + (dir / "bad.rgs").string() + " --port 0");
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(test::is_one_error_line(r.err)) << r.err;
  EXPECT_NE(r.err.find("bad.rgs"), std::string::npos) << r.err;
}

TEST(ViewCli, PortInUseIsRefused) {
  // A listening socket on a free port of 127.0.0.1, held by this test.
  const int sock = socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(sock, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t length = sizeof(address);
  ASSERT_EQ(bind(sock, reinterpret_cast<sockaddr*>(&address), length), 0);
  ASSERT_EQ(listen(sock, 1), 0);
  ASSERT_EQ(getsockname(sock, reinterpret_cast<sockaddr*>(&address), &length), 0);
  const int port = ntohs(address.sin_port);
  test::TempDir dir;
  model::write_model(dir / "model.rgs", test::view_fixture_model(20, 2));
  const auto r = test::run_cli("view --model " + (dir / "model.rgs").string() + " --port " +
                               std::to_string(port));
  close(sock);
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(test::is_one_error_line(r.err)) << r.err;
  EXPECT_NE(r.err.find("cannot listen on 127.0.0.1:" + std::to_string(port)), std::string::npos)
      << r.err;
}

// The server answers on its port until a signal, then exits as any interrupted command: 130 after
// Ctrl-C, 143 after SIGTERM, in one line.
TEST(ViewCli, CtrlCAndSigtermStopTheServer) {
  test::TempDir dir;
  model::write_model(dir / "model.rgs", test::view_fixture_model(20, 2));
  for (const int sig : {SIGINT, SIGTERM}) {
    // A free port of 127.0.0.1: bound, read, released.
    const int probe = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t length = sizeof(address);
    ASSERT_EQ(bind(probe, reinterpret_cast<sockaddr*>(&address), length), 0);
    ASSERT_EQ(getsockname(probe, reinterpret_cast<sockaddr*>(&address), &length), 0);
    close(probe);
    test::CliProcess server({"view", "--model", (dir / "model.rgs").string(), "--port",
                             std::to_string(ntohs(address.sin_port))},
                            dir / "view.err");
    const auto accepts = [&] {
      const int sock = socket(AF_INET, SOCK_STREAM, 0);
      const bool ok = connect(sock, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0;
      close(sock);
      return ok;
    };
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (!accepts() && std::chrono::steady_clock::now() < until)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    ASSERT_TRUE(accepts()) << server.err();
    server.signal(sig);
    const auto ended = [](const std::string& err) { return !err.empty(); };
    ASSERT_TRUE(server.wait_for_err(ended, 30)) << "still serving after signal " << sig;
    EXPECT_EQ(server.wait(), 128 + sig);
    EXPECT_TRUE(test::is_one_error_line(server.err())) << server.err();
  }
}

TEST(ViewCli, ExportWebWritesTheViewerWithTheScene) {
  test::TempDir dir;
  model::write_model(dir / "model.rgs", test::view_fixture_model(50, 2));
  fs::create_directories(dir / "scene");
  io::write_scene_json(test::view_fixture_scene(dir / "scene"));
  const auto r = test::run_cli("export --model " + (dir / "model.rgs").string() + " --scene " +
                               (dir / "scene").string() + " --web " + (dir / "site").string());
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* name : {"index.html", "main.js", "model.json", "model.bin"})
    EXPECT_TRUE(fs::exists(dir / "site" / name)) << name;
  std::ifstream in(dir / "site" / "model.json");
  EXPECT_EQ(json::parse(in)["cameras"].size(), 2u);
  const auto again = test::run_cli("export --model " + (dir / "model.rgs").string() + " --web " +
                                   (dir / "site").string());
  EXPECT_EQ(again.status, 2);  // exists: --force needed
  EXPECT_TRUE(test::is_one_error_line(again.err)) << again.err;
}

}  // namespace
}  // namespace retimegs
