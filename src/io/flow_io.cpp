#include "retimegs/io/flow_io.hpp"

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <vector>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/input_file.hpp"

namespace retimegs::io {
namespace fs = std::filesystem;

namespace {
constexpr float kFloTag = 202021.25f;  // the bytes "PIEH" read as a little-endian float
constexpr std::int32_t kMaxFloSide = 1 << 16;
}  // namespace

Flow read_flo(const fs::path& path) {
  const std::string name = path.string();
  check_input_file(path, "a .flo file");
  if (!fs::is_regular_file(path)) fail("{}: no such file", name);
  const std::uintmax_t found = fs::file_size(path);
  if (found < 12) fail("{}: truncated .flo (expected at least 12 bytes, found {})", name, found);
  float tag = 0;
  std::int32_t w = 0, h = 0;
  std::ifstream in(path, std::ios::binary);
  in.read(reinterpret_cast<char*>(&tag), 4);
  in.read(reinterpret_cast<char*>(&w), 4);
  in.read(reinterpret_cast<char*>(&h), 4);
  if (!in) fail("{}: cannot read .flo header", name);
  if (tag != kFloTag) fail("{}: bad .flo tag {} (expected 202021.25, \"PIEH\")", name, tag);
  if (w <= 0 || h <= 0 || w >= kMaxFloSide || h >= kMaxFloSide)
    fail("{}: invalid .flo size {}x{}", name, w, h);
  const std::uintmax_t expected = 12 + std::uintmax_t(w) * h * 8;
  if (found < expected)
    fail("{}: truncated .flo (expected {} bytes, found {})", name, expected, found);
  if (found > expected)
    fail("{}: trailing data after .flo values (expected {} bytes, found {})", name, expected,
         found);

  std::vector<float> uv(std::size_t(w) * h * 2);
  in.read(reinterpret_cast<char*>(uv.data()), std::streamsize(uv.size() * sizeof(float)));
  if (!in) fail("{}: cannot read the .flo values", name);
  Flow flow(w, h);
  for (std::size_t i = 0; i < flow.pixels(); ++i) {
    const float u = uv[2 * i], v = uv[2 * i + 1];
    if (std::isnan(u) || std::isnan(v)) fail("{}: NaN flow at pixel ({}, {})", name, i % w, i / w);
    if (std::abs(u) > kUnknownFlowThreshold || std::abs(v) > kUnknownFlowThreshold) {
      flow.valid[i] = 0;  // uv stays 0
    } else {
      flow.uv[2 * i] = u;
      flow.uv[2 * i + 1] = v;
    }
  }
  return flow;
}

void write_flo(const fs::path& path, const Flow& flow) {
  const std::string name = path.string();
  const int w = flow.width, h = flow.height;
  if (w <= 0 || h <= 0 || w >= kMaxFloSide || h >= kMaxFloSide)
    fail("{}: invalid flow size {}x{}", name, w, h);
  if (flow.uv.size() != 2 * flow.pixels() || flow.valid.size() != flow.pixels())
    fail("{}: flow buffers do not match its size {}x{}", name, w, h);
  std::vector<float> uv(2 * flow.pixels());
  for (std::size_t i = 0; i < flow.pixels(); ++i) {
    const float u = flow.uv[2 * i], v = flow.uv[2 * i + 1];
    if (!flow.valid[i]) {
      uv[2 * i] = uv[2 * i + 1] = kUnknownFlowValue;
    } else if (!(std::abs(u) <= kUnknownFlowThreshold && std::abs(v) <= kUnknownFlowThreshold)) {
      // Non-finite, or so large that it would read back as unknown.
      fail("{}: flow ({}, {}) at known pixel ({}, {}) is not finite or exceeds 1e9", name, u, v,
           i % w, i / w);
    } else {
      uv[2 * i] = u;
      uv[2 * i + 1] = v;
    }
  }
  AtomicFile file(path);  // the temporary name keeps the .flo extension
  {
    errno = 0;
    std::ofstream out(file.temp_path(), std::ios::binary);
    const std::int32_t header[2] = {w, h};
    out.write(reinterpret_cast<const char*>(&kFloTag), 4);
    out.write(reinterpret_cast<const char*>(header), 8);
    out.write(reinterpret_cast<const char*>(uv.data()), std::streamsize(uv.size() * sizeof(float)));
    out.close();
    check_written(out, path);
  }
  file.commit();
}

}  // namespace retimegs::io
