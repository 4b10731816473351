#pragma once
// LPIPS v0.1 (Zhang et al. 2018, "net='squeeze'", spatial average) with the SqueezeNet 1.1 trunk,
// exactly as data/lpips_squeeze/manifest.json defines it:
//   x = (2v − 1 − shift) / scale per channel (v: RGB in [0, 1]);
//   conv 3→64 k3 s2 + ReLU → tap0; max-pool k3 s2 ceil_mode, Fire 3, Fire 4 → tap1;
//   max-pool, Fire 6, Fire 7 → tap2; max-pool, Fire 9 → tap3; Fire 10 → tap4; Fire 11 → tap5;
//   Fire 12 → tap6 (Fire: squeeze 1×1 + ReLU, then [expand 1×1 + ReLU, expand 3×3 pad 1 + ReLU]);
//   per tap: f / (‖f‖₂ over channels + 1e-10), squared difference, 1×1 linear layer to one
//   channel, mean over the pixels; LPIPS = the sum over the 7 taps.
// The trunk runs in float (im2col + Eigen GEMM, OpenMP), the head in double.
#include <array>
#include <filesystem>
#include <vector>

#include "retimegs/core/image.hpp"

namespace retimegs::eval {

// A stack of planar feature maps.
struct FeatureMap {
  int channels = 0, height = 0, width = 0;
  std::vector<float> data;  // [C, H, W]
};

class Lpips {
 public:
  static constexpr int kTaps = 7;
  // 25 px: conv k3 s2 → 12, then the three k3 s2 ceil-mode pools → 6 → 3 → 1; 24 px would give
  // 11 → 5 → 2, too small for the last 3×3 pool.
  static constexpr int kMinSide = 25;

  // Reads `<dir>/<key>.npy` for the 57 keys of the manifest (the repository's copy:
  // data/lpips_squeeze/weights); throws Error naming the folder when it is
  // missing, or the file when one is missing, malformed or of the wrong shape.
  static Lpips load(const std::filesystem::path& dir);

  // LPIPS distance of two RGB images in [0, 1] of the same size, each side ≥ kMinSide. Throws
  // Error on a size or channel mismatch, a non-finite value or a too small image.
  double distance(const Image& a, const Image& b) const;
  // The seven per-tap terms whose sum is distance().
  std::array<double, kTaps> tap_distances(const Image& a, const Image& b) const;
  // The seven tap activations of one image (after the ReLU, before the normalisation).
  std::array<FeatureMap, kTaps> features(const Image& image) const;

 private:
  struct Conv {
    int out = 0, in = 0, kernel = 0;
    std::vector<float> weight;  // [out, in, k, k]
    std::vector<float> bias;    // [out]
  };
  struct Fire {
    Conv squeeze, expand1x1, expand3x3;
  };

  Lpips() = default;
  // ReLU(conv(x)) with zero padding `pad`, written to out [conv.out, H', W'].
  static void conv_relu(const Conv& conv, const FeatureMap& x, int stride, int pad, float* out);
  // ReLU(squeeze), then [ReLU(expand 1×1), ReLU(expand 3×3, pad 1)] concatenated over channels.
  static FeatureMap fire(const Fire& fire, const FeatureMap& x);

  Conv conv0_;                                 // features.0
  std::array<Fire, 8> fires_;                  // features.3, 4, 6, 7, 9, 10, 11, 12
  std::array<std::vector<float>, kTaps> lin_;  // [C_k] lin{k}.model.1.weight
};

}  // namespace retimegs::eval
