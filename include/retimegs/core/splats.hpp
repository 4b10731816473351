#pragma once
// A static 3DGS model in its stored (pre-activation) form — what the Inria `.ply` layout holds and
// what `retimegs export` writes for one time: means, log-scales, raw quaternions, opacity logits
// and spherical-harmonic colour coefficients. model/ turns it into renderable Gaussians for a
// camera; io/ reads and writes it.
#include <cstddef>
#include <vector>

namespace retimegs {

struct Splats {
  int sh_degree = 0;                  // 0..3; K = (sh_degree + 1)^2 coefficients per channel
  std::vector<float> means;           // [N, 3]
  std::vector<float> log_scales;      // [N, 3]
  std::vector<float> quats;           // [N, 4] (w, x, y, z), unnormalised
  std::vector<float> opacity_logits;  // [N]
  std::vector<float> sh;              // [N, K, 3] coefficient-major, RGB innermost

  std::size_t size() const { return opacity_logits.size(); }
  int sh_coeffs() const { return (sh_degree + 1) * (sh_degree + 1); }
};

}  // namespace retimegs
