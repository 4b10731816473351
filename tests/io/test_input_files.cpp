// Every parser that opens a path refuses what is not a regular file itself (core/input_file.hpp),
// so that no command can forget it: a FIFO would block the open (or the read) for ever, a device
// never end, a folder fail with an unrelated message.
#include <sys/stat.h>

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "retimegs/core/error.hpp"
#include "retimegs/io/camera_path_json.hpp"
#include "retimegs/io/colmap.hpp"
#include "retimegs/io/flow_io.hpp"
#include "retimegs/io/npy.hpp"
#include "retimegs/io/ply.hpp"
#include "retimegs/io/splat_ply.hpp"
#include "retimegs/media/frame_writer.hpp"
#include "retimegs/media/image_io.hpp"
#include "test_util.hpp"

namespace retimegs::io {
namespace {
namespace fs = std::filesystem;

TEST(InputFiles, EveryParserRefusesFifosAndFoldersNamingThePath) {
  test::TempDir dir;
  const fs::path fifo = dir / "input.fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  fs::create_directories(dir / "colmap");
  ASSERT_EQ(::mkfifo((dir / "colmap" / "cameras.txt").c_str(), 0644), 0);
  test::write_text(dir / "colmap" / "images.txt", "");
  test::write_text(dir / "colmap" / "points3D.txt", "");
  const std::vector<std::pair<std::string, std::function<void(const fs::path&)>>> parsers = {
      {"read_flo", [](const fs::path& p) { read_flo(p); }},
      {"read_npy", [](const fs::path& p) { read_npy(p); }},
      {"read_points_ply", [](const fs::path& p) { read_points_ply(p); }},
      {"read_splat_ply", [](const fs::path& p) { read_splat_ply(p); }},
      {"read_retime_csv", [](const fs::path& p) { media::read_retime_csv(p); }},
      {"read_camera_path_json", [](const fs::path& p) { read_camera_path_json(p); }},
      {"read_image", [](const fs::path& p) { media::read_image(p); }},
  };
  for (const auto& entry : parsers) {  // no structured binding: clang 14 cannot capture one
    const std::string& name = entry.first;
    const auto& parse = entry.second;
    const std::string on_fifo = test::message_of([&] { parse(fifo); });
    EXPECT_NE(on_fifo.find(fifo.string()), std::string::npos) << name << ": " << on_fifo;
    EXPECT_NE(on_fifo.find("FIFO"), std::string::npos) << name << ": " << on_fifo;
    const std::string on_folder = test::message_of([&] { parse(dir / "colmap"); });
    EXPECT_NE(on_folder.find("folder"), std::string::npos) << name << ": " << on_folder;
  }
  const std::string colmap = test::message_of([&] { read_colmap_model(dir / "colmap"); });
  EXPECT_NE(colmap.find((dir / "colmap" / "cameras.txt").string()), std::string::npos) << colmap;
  EXPECT_NE(colmap.find("FIFO"), std::string::npos) << colmap;
}

}  // namespace
}  // namespace retimegs::io
