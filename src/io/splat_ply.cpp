#include "retimegs/io/splat_ply.hpp"

#include <cmath>

#include <fmt/format.h>

#include "retimegs/core/error.hpp"
#include "retimegs/io/ply.hpp"

namespace retimegs::io {

namespace {
constexpr int kRestPerChannel = 15;  // degree 3: 16 coefficients, minus the DC term
}

Splats read_splat_ply(const std::filesystem::path& path) {
  const PlyTable table = read_ply(path);
  const std::string file = path.string();
  auto column = [&](const std::string& name) -> const std::vector<float>& {
    if (!table.has(name)) fail("{}: not a 3DGS splat file: missing property '{}'", file, name);
    return table.column(name);
  };
  int rest = 0;
  while (table.has(fmt::format("f_rest_{}", rest))) ++rest;
  Splats s;
  switch (rest) {
    case 0:
      s.sh_degree = 0;
      break;
    case 9:
      s.sh_degree = 1;
      break;
    case 24:
      s.sh_degree = 2;
      break;
    case 45:
      s.sh_degree = 3;
      break;
    default:
      fail("{}: {} f_rest properties; a 3DGS file has 0, 9, 24 or 45", file, rest);
  }
  const std::size_t n = table.count;
  const int k = s.sh_coeffs(), rest_per_channel = k - 1;
  s.means.resize(3 * n);
  s.log_scales.resize(3 * n);
  s.quats.resize(4 * n);
  s.opacity_logits = column("opacity");
  s.sh.resize(n * k * 3);
  const char* axes[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    const auto& pos = column(axes[a]);
    const auto& scale = column(fmt::format("scale_{}", a));
    const auto& dc = column(fmt::format("f_dc_{}", a));
    for (std::size_t i = 0; i < n; ++i) {
      s.means[3 * i + a] = pos[i];
      s.log_scales[3 * i + a] = scale[i];
      s.sh[(i * k) * 3 + a] = dc[i];
    }
    for (int j = 0; j < rest_per_channel; ++j) {
      const auto& coeff = column(fmt::format("f_rest_{}", a * rest_per_channel + j));
      for (std::size_t i = 0; i < n; ++i) s.sh[(i * k + 1 + j) * 3 + a] = coeff[i];
    }
  }
  for (int r = 0; r < 4; ++r) {
    const auto& rot = column(fmt::format("rot_{}", r));
    for (std::size_t i = 0; i < n; ++i) s.quats[4 * i + r] = rot[i];
  }
  for (const auto* field : {&s.means, &s.log_scales, &s.quats, &s.opacity_logits, &s.sh})
    for (std::size_t i = 0; i < field->size(); ++i)
      if (!std::isfinite((*field)[i]))
        fail("{}: non-finite value in splat {}", file, i * n / field->size());
  for (std::size_t i = 0; i < n; ++i)
    if (s.quats[4 * i] == 0 && s.quats[4 * i + 1] == 0 && s.quats[4 * i + 2] == 0 &&
        s.quats[4 * i + 3] == 0)
      fail("{}: splat {} has a zero quaternion", file, i);
  return s;
}

void write_splat_ply(const std::filesystem::path& path, const Splats& s, bool replace) {
  const std::size_t n = s.size();
  const int k = s.sh_coeffs();
  PlyTable table;
  table.count = n;
  auto strided = [&](const std::vector<float>& v, int stride, int offset) {
    std::vector<float> out(n);
    for (std::size_t i = 0; i < n; ++i) out[i] = v[i * stride + offset];
    return out;
  };
  const char* axes[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) table.add(axes[a], strided(s.means, 3, a));
  for (const char* normal : {"nx", "ny", "nz"}) table.add(normal, std::vector<float>(n, 0.0f));
  for (int c = 0; c < 3; ++c) table.add(fmt::format("f_dc_{}", c), strided(s.sh, 3 * k, c));
  for (int c = 0; c < 3; ++c)
    for (int j = 0; j < kRestPerChannel; ++j)
      table.add(fmt::format("f_rest_{}", c * kRestPerChannel + j),
                j + 1 < k ? strided(s.sh, 3 * k, 3 * (j + 1) + c) : std::vector<float>(n, 0.0f));
  table.add("opacity", s.opacity_logits);
  for (int a = 0; a < 3; ++a) table.add(fmt::format("scale_{}", a), strided(s.log_scales, 3, a));
  for (int r = 0; r < 4; ++r) table.add(fmt::format("rot_{}", r), strided(s.quats, 4, r));
  write_ply(path, table, replace);
}

}  // namespace retimegs::io
