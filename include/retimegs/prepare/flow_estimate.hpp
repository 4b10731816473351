#pragma once
// Built-in dense optical flow for `retimegs prepare` (OpenCV and opencv_contrib's optflow), and
// the forward-backward consistency check that marks occluded / unreliable pixels unknown.
// bench/flow_bench.cpp measures every method against data/flow's ground truth (bench/README.md).
#include <cstddef>
#include <string>
#include <vector>

#include "retimegs/core/image.hpp"

namespace retimegs::prepare {

enum class FlowMethod {
  kDis,               // DIS (Kroeger et al. 2016), MEDIUM at full resolution, patch stride 2
  kDisUltrafast,      // DIS, OpenCV's ULTRAFAST preset as it is
  kDisFast,           // DIS, FAST preset
  kDisMedium,         // DIS, MEDIUM preset
  kDisUltrafastFine,  // ULTRAFAST down to full resolution, with variational refinement
  kDisFastFine,       // FAST down to full resolution
  kDeepFlow,          // DeepFlow (Weinzaepfel et al. 2013), opencv_contrib optflow defaults
  kTvl1,              // Dual TV-L1 (Zach et al. 2007), opencv_contrib optflow defaults
  kRlof,              // dense RLOF (Senst et al. 2012), optflow defaults, on the colour image
  kPcaFlow,           // PCA-Flow (Wulff & Black 2015), optflow defaults
  kFarneback,         // Farnebäck (2003), OpenCV video defaults
};

// Every method, in FlowMethod's order.
const std::vector<FlowMethod>& flow_methods();
// Its name on the command line ("dis", "dis-fast", "rlof", ...).
const char* flow_method_name(FlowMethod method);
// "dis, dis-ultrafast, ...", for help texts and errors.
std::string flow_method_names();
// The method of `name`; throws Error naming `flag`, the value and the names otherwise.
FlowMethod parse_flow_method(const std::string& name, const std::string& flag = "--flow");

// The 8-bit grey image every estimator sees: RGB in [0, 1] rounded to 8 bits, then OpenCV's
// cvtColor(RGB2GRAY) (0.299 R + 0.587 G + 0.114 B), the reference conversion of the yardsticks
// in data/flow/README.md. One-channel images are taken as grey.
// [H, W] row-major.
std::vector<unsigned char> to_gray8(const Image& image);

// Dense flow from `from` to `to` (same size, 1 or 3 channels): pixel (x, y) of `from` moves to
// (x + u, y + v) in `to`. Every pixel is valid. Single-threaded or OpenCV-parallel depending on
// cv::getNumThreads() of the caller.
Flow estimate_flow(const Image& from, const Image& to, FlowMethod method = FlowMethod::kDis);

// A flow against ground truth over the pixels where `mask` is set (non-zero): the mean end-point
// error in pixels, and the share of outliers, KITTI's Fl (an end-point error above 3 px and above
// 5 % of the true motion's length).
struct FlowErrors {
  double epe = 0, outliers = 0;
  std::size_t pixels = 0;
};
FlowErrors flow_errors(const Flow& flow, const Flow& truth, const std::vector<unsigned char>& mask);

// Forward-backward consistency (Sundaram, Brox & Keutzer, "Dense point trajectories by
// GPU-accelerated large displacement optical flow", ECCV 2010, eq. 5; the same test with
// alpha1 = 0.01, alpha2 = 0.5 is the occlusion mask of UnFlow, Meister et al., AAAI 2018):
// pixel x with forward flow f = F(x) and backward flow b = B(x + f) (bilinear) is consistent when
//   |f + b|^2 < alpha1 (|f|^2 + |b|^2) + alpha2.
struct ConsistencyOptions {
  double alpha1 = 0.01;  // relative tolerance: grows with the motion (1 px at ~7 px of motion)
  double alpha2 = 0.5;   // absolute tolerance, pixels^2 (~0.7 px of round-trip error)
};

// Marks unknown (valid = 0, uv = 0) every pixel of `forward` that fails the test against
// `backward`, lands outside the image (x + f outside [0, W) x [0, H), pixel centres at +0.5), or
// whose backward sample touches an unknown pixel. Returns how many pixels it newly marked.
// `forward` and `backward` must have the same size.
std::size_t mark_inconsistent(Flow& forward, const Flow& backward,
                              const ConsistencyOptions& options = {});

struct FlowPair {
  Flow forward;   // a -> b
  Flow backward;  // b -> a
};

// Both directions between `a` and `b`, each checked against the other (the check uses the raw
// estimates of both, so its outcome does not depend on the order).
FlowPair estimate_flow_pair(const Image& a, const Image& b, FlowMethod method = FlowMethod::kDis,
                            const ConsistencyOptions& options = {});

}  // namespace retimegs::prepare
