#pragma once
// A calibration written as the rig file `import videos --calib` reads (docs/cli.md, "Rig file"):
// JSON, a sequence of cameras with name, K, R, t, width and height, no distortion. The reader is
// ingest's (OpenCV's FileStorage); the same file goes back into any tool that takes a rig.
#include <filesystem>
#include <string>
#include <vector>

#include "retimegs/core/camera.hpp"

namespace retimegs::io {

// The rig file's text for `cameras`, in their order. K follows OpenCV's pixel convention (the
// centre of the top-left pixel at (0, 0)): the scene format's principal point less half a pixel.
std::string rig_json(const std::vector<Camera>& cameras);

// Writes rig_json(cameras) to `file` atomically.
void write_rig_file(const std::filesystem::path& file, const std::vector<Camera>& cameras);

}  // namespace retimegs::io
