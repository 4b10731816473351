#pragma once
// PLY vertex tables: binary little/big-endian and ASCII in, binary little-endian out.
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace retimegs::io {

// The "vertex" element of a PLY file as named float columns (every scalar type is converted;
// list properties are refused). Used for point clouds and for 3DGS splat files (Inria layout).
struct PlyTable {
  std::size_t count = 0;
  std::vector<std::string> names;           // property names in file order
  std::vector<std::vector<float>> columns;  // [P][count]

  bool has(const std::string& name) const;
  // Throws Error naming `name` when absent.
  const std::vector<float>& column(const std::string& name) const;
  void add(const std::string& name, std::vector<float> values);
};

// Throws Error naming the file on a missing file, a malformed header, no vertex element, or a
// truncated body.
PlyTable read_ply(const std::filesystem::path& path);

// Writes every column as float32, except that columns named red/green/blue are written as uchar
// (values 0..255) for viewer compatibility. Atomic; an existing `path` is replaced only with
// `replace` (core/atomic_file.hpp).
void write_ply(const std::filesystem::path& path, const PlyTable& table, bool replace = true);

// A world-space point cloud: xyz and optional colours in [0, 1].
struct PointCloud {
  std::vector<float> xyz;  // [N, 3]
  std::vector<float> rgb;  // [N, 3] or empty
  std::size_t size() const { return xyz.size() / 3; }
};

// x, y, z required (float or double); red, green, blue optional (uchar 0..255 or float 0..1).
// Rejects non-finite coordinates.
PointCloud read_points_ply(const std::filesystem::path& path);
void write_points_ply(const std::filesystem::path& path, const PointCloud& points);

}  // namespace retimegs::io
