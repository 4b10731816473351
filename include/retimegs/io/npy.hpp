#pragma once
// NumPy .npy arrays (format 1.0/2.0, little-endian float32 / float64 / int32, C order).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace retimegs::io {

struct NpyArray {
  enum class Type { kFloat32, kFloat64, kInt32 };
  Type type = Type::kFloat32;
  std::vector<std::size_t> shape;
  std::vector<double> values;  // every element converted to double (exact for all three types)

  std::size_t size() const { return values.size(); }
  std::vector<float> to_float() const;
  std::vector<std::int32_t> to_int() const;
};

// Throws Error naming the file on a missing file, bad magic, an unsupported dtype, Fortran order,
// a malformed header or a truncated body.
NpyArray read_npy(const std::filesystem::path& path);

// Writes float32 (little-endian, C order), atomically.
void write_npy(const std::filesystem::path& path, const std::vector<std::size_t>& shape,
               const std::vector<float>& values);

}  // namespace retimegs::io
