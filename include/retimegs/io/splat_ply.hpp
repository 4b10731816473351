#pragma once
// The standard 3DGS `.ply` (the Inria layout that SuperSplat and other viewers open): binary
// little-endian float32 `x y z nx ny nz f_dc_0..2 f_rest_0..44 opacity scale_0..2 rot_0..3`,
// values before activation, `f_rest` channel-major (all red coefficients, then green, then blue).
#include <filesystem>

#include "retimegs/core/splats.hpp"

namespace retimegs::io {

// Accepts any PLY (ASCII or binary) with those properties; the SH degree follows from the number
// of f_rest properties (0, 9, 24 or 45). Throws Error naming the file and the missing property or
// the first non-finite value.
Splats read_splat_ply(const std::filesystem::path& path);

// Writes the exact Inria property list (45 f_rest, zero above the model's degree); atomic, as
// write_ply.
void write_splat_ply(const std::filesystem::path& path, const Splats& splats, bool replace = true);

}  // namespace retimegs::io
