#pragma once
// Structural similarity as 3DGS trains and evaluates it (docs/method.md: image loss, evaluation):
// an 11×11 Gaussian window (σ = 1.5, normalised to sum 1) applied per channel as a zero-padded
// "same" correlation (conv2d with padding 5), C1 = 0.01², C2 = 0.03² for values in [0, 1], and the
// SSIM map averaged over all H×W×C, borders included. Cropping the map by 5 px gives the Gaussian
// SSIM of Wang et al. 2004 over valid windows (scikit-image gaussian_weights=True).
//
// Moments, the map and the gradient are accumulated in double: σ² = E[x²] − μ² cancels badly in
// float (3DGS's float32 value differs by ~1.3e-5 from the exact one).
#include <vector>

#include "retimegs/core/image.hpp"

namespace retimegs {

// Mean SSIM of a and b (same width, height and channel count; any number of channels). `map`,
// when given, receives the per-pixel, per-channel SSIM [H, W, C]. Throws Error on a size mismatch.
double ssim(const Image& a, const Image& b, Image* map = nullptr);

// Mean SSIM, and its vector-Jacobian product with respect to the first image (the render; b is
// the constant target): v_a = v_ssim · d ssim / d a, written (not accumulated) as [H, W, C].
// The training loss λ·(1 − SSIM) passes v_ssim = −λ.
double ssim_backward(const Image& a, const Image& b, double v_ssim, Image& v_a);

// The target side of SSIM, prepared once for several renders compared with one image (a training
// step's three renders against its view): the window moments μ_b and E[b²] of the target, which
// the render's moments do not change. assign() borrows `b` (it must outlive the target's use)
// and reuses the arrays' capacity.
struct SsimTarget {
  const Image* image = nullptr;
  std::vector<double> mu, e_sq;  // [H, W, C] μ_b and E[b²] of each window, in double

  void assign(const Image& b);
};

// Mean SSIM of a against the prepared target, adding v_ssim · d ssim / d a into the first
// a.channels channels of v_out ([H, W, C'] with C' >= C: a render's gradient with more channels).
// The same values as ssim_backward. Throws Error on a size mismatch or an unprepared target.
double ssim_backward_add(const Image& a, const SsimTarget& b, double v_ssim, Image& v_out);

// Slow, obviously correct versions for tests: direct 11×11 double sums per pixel, and the gradient
// as the explicit sum over every window that contains the pixel.
double ssim_reference(const Image& a, const Image& b, Image* map = nullptr);
double ssim_backward_reference(const Image& a, const Image& b, double v_ssim, Image& v_a);

}  // namespace retimegs
