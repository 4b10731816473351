#pragma once
// Middlebury .flo files: the float tag 202021.25 ("PIEH"), int32 width and height, then
// width x height (u, v) float pairs row by row, all little-endian.
#include <filesystem>

#include "retimegs/core/image.hpp"

namespace retimegs::io {

// 1e9: Middlebury's UNKNOWN_FLOW_THRESH; components above it mark unknown pixels.
constexpr float kUnknownFlowThreshold = 1e9f;
// 1e10: Middlebury's UNKNOWN_FLOW, the value written for unknown pixels.
constexpr float kUnknownFlowValue = 1e10f;

// Throws Error naming the file when it is missing, has a bad tag, a non-positive size, is truncated
// or holds NaN. Unknown pixels become valid = 0, uv = 0.
Flow read_flo(const std::filesystem::path& path);

// Writes unknown pixels as kUnknownFlowValue; atomic. Rejects non-finite values of known pixels.
void write_flo(const std::filesystem::path& path, const Flow& flow);

}  // namespace retimegs::io
