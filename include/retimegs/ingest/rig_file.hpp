#pragma once
// A rig file (docs/cli.md, "Rig file") read as the scene format's pinhole cameras: what
// io::write_rig_file writes (calibration_true.json beside a perturbed scene) read back.
#include <filesystem>
#include <vector>

#include "retimegs/core/camera.hpp"

namespace retimegs::ingest {

// The rig's cameras in file order, principal points in the scene format's pixel convention.
// Throws Error naming the file and the camera for one with distortion or without a size (those
// need footage: `import videos`), and as `import videos --calib` does for a malformed file.
std::vector<Camera> read_rig_cameras(const std::filesystem::path& file);

}  // namespace retimegs::ingest
