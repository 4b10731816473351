#include "retimegs/prepare/flow_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "contrib_flow.hpp"
#include "retimegs/core/error.hpp"

namespace retimegs::prepare {

namespace {

// DIS settings: OpenCV's MEDIUM preset (patch 8, 25 gradient-descent iterations, 5 variational
// refinement iterations) with the finest scale 0 instead of 1, i.e. patches are matched on the
// full-resolution image rather than at half resolution and upsampled, and a patch stride of 2
// instead of 3. On the 5 reference pairs of data/flow this lowers the EPE of MEDIUM by 5-50 %
// (table in README.md, "Prepare") for ~5x its time (~0.1 s for a 256x192 pair on one core).
constexpr int kDisFinestScale = 0;
constexpr int kDisPatchStride = 2;

// Variational refinement iterations of the "-fine" DIS variants (those of OpenCV's FAST and
// MEDIUM presets; ULTRAFAST has none).
constexpr int kDisFineRefinement = 5;

// `image` at 8 bits per value, its channels as they are (1 or 3): [0, 1] rounded to nearest.
cv::Mat to_mat8(const Image& image) {
  if (image.channels != 1 && image.channels != 3)
    fail("optical flow: expected a 1- or 3-channel image, got {} channels", image.channels);
  cv::Mat m(image.height, image.width, image.channels == 1 ? CV_8UC1 : CV_8UC3);
  for (int y = 0; y < image.height; ++y) {
    unsigned char* row = m.ptr<unsigned char>(y);
    const float* src = image.pixel(y, 0);
    for (int i = 0; i < image.width * image.channels; ++i)
      row[i] = cv::saturate_cast<unsigned char>(src[i] * 255.0f);  // rounds to nearest
  }
  return m;
}

// The 8-bit image every estimator sees: grey (to_gray8), or RGB for RLOF, which needs three
// channels (a grey image is repeated in each).
cv::Mat estimator_input(const Image& image, FlowMethod method) {
  if (method == FlowMethod::kRlof) {
    const cv::Mat values = to_mat8(image);
    if (image.channels == 3) return values;
    cv::Mat rgb;
    cv::cvtColor(values, rgb, cv::COLOR_GRAY2RGB);
    return rgb;
  }
  std::vector<unsigned char> gray = to_gray8(image);
  return cv::Mat(image.height, image.width, CV_8UC1, gray.data()).clone();
}

Flow from_mat(const cv::Mat& m) {
  if (m.type() != CV_32FC2) fail("optical flow: OpenCV returned a flow of type {}", m.type());
  Flow flow(m.cols, m.rows);
  for (int y = 0; y < m.rows; ++y) {
    const float* row = m.ptr<float>(y);
    std::copy(row, row + 2 * m.cols, flow.uv.begin() + std::size_t(y) * m.cols * 2);
  }
  return flow;
}

cv::Ptr<cv::DISOpticalFlow> dis(int preset, bool fine) {
  auto dis = cv::DISOpticalFlow::create(preset);
  if (fine) {
    dis->setFinestScale(0);
    dis->setVariationalRefinementIterations(kDisFineRefinement);
  }
  return dis;
}

cv::Ptr<cv::DenseOpticalFlow> make_estimator(FlowMethod method) {
  switch (method) {
    case FlowMethod::kDis: {
      auto estimator = cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_MEDIUM);
      estimator->setFinestScale(kDisFinestScale);
      estimator->setPatchStride(kDisPatchStride);
      return estimator;
    }
    case FlowMethod::kDisUltrafast:
      return dis(cv::DISOpticalFlow::PRESET_ULTRAFAST, false);
    case FlowMethod::kDisFast:
      return dis(cv::DISOpticalFlow::PRESET_FAST, false);
    case FlowMethod::kDisMedium:
      return dis(cv::DISOpticalFlow::PRESET_MEDIUM, false);
    case FlowMethod::kDisUltrafastFine:
      return dis(cv::DISOpticalFlow::PRESET_ULTRAFAST, true);
    case FlowMethod::kDisFastFine:
      return dis(cv::DISOpticalFlow::PRESET_FAST, true);
    case FlowMethod::kDeepFlow:
    case FlowMethod::kTvl1:
    case FlowMethod::kRlof:
    case FlowMethod::kPcaFlow:
      return detail::contrib_estimator(method);
    case FlowMethod::kFarneback:
      return cv::FarnebackOpticalFlow::create();
  }
  fail("optical flow: unknown method {}", int(method));
}

// Every method with its name, in FlowMethod's order.
constexpr std::pair<FlowMethod, const char*> kMethods[] = {
    {FlowMethod::kDis, "dis"},
    {FlowMethod::kDisUltrafast, "dis-ultrafast"},
    {FlowMethod::kDisFast, "dis-fast"},
    {FlowMethod::kDisMedium, "dis-medium"},
    {FlowMethod::kDisUltrafastFine, "dis-ultrafast-fine"},
    {FlowMethod::kDisFastFine, "dis-fast-fine"},
    {FlowMethod::kDeepFlow, "deepflow"},
    {FlowMethod::kTvl1, "tvl1"},
    {FlowMethod::kRlof, "rlof"},
    {FlowMethod::kPcaFlow, "pcaflow"},
    {FlowMethod::kFarneback, "farneback"},
};

// Bilinear sample of `flow` at continuous pixel coordinates (u, v) (centres at +0.5), clamped to
// the image; false when one of the taps with a non-zero weight is unknown.
bool sample_flow(const Flow& flow, double u, double v, double& fu, double& fv) {
  const double x = std::clamp(u - 0.5, 0.0, double(flow.width - 1));
  const double y = std::clamp(v - 0.5, 0.0, double(flow.height - 1));
  const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
  const int x1 = std::min(x0 + 1, flow.width - 1), y1 = std::min(y0 + 1, flow.height - 1);
  const double ax = x - x0, ay = y - y0;
  const int xs[2] = {x0, x1}, ys[2] = {y0, y1};
  const double wx[2] = {1 - ax, ax}, wy[2] = {1 - ay, ay};
  fu = fv = 0;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      const double w = wx[i] * wy[j];
      if (w == 0) continue;
      const std::size_t p = std::size_t(ys[j]) * flow.width + xs[i];
      if (!flow.valid[p]) return false;
      fu += w * flow.uv[2 * p];
      fv += w * flow.uv[2 * p + 1];
    }
  return true;
}

}  // namespace

const std::vector<FlowMethod>& flow_methods() {
  static const std::vector<FlowMethod> methods = [] {
    std::vector<FlowMethod> all;
    for (const auto& [method, name] : kMethods) all.push_back(method);
    return all;
  }();
  return methods;
}

const char* flow_method_name(FlowMethod method) {
  for (const auto& [m, name] : kMethods)
    if (m == method) return name;
  fail("optical flow: unknown method {}", int(method));
}

std::string flow_method_names() {
  std::string names;
  for (const auto& [method, name] : kMethods)
    names += (names.empty() ? "" : ", ") + std::string(name);
  return names;
}

FlowMethod parse_flow_method(const std::string& name, const std::string& flag) {
  for (const auto& [method, n] : kMethods)
    if (name == n) return method;
  fail("{}: unknown flow method '{}' ({})", flag, name, flow_method_names());
}

std::vector<unsigned char> to_gray8(const Image& image) {
  const cv::Mat values = to_mat8(image);
  cv::Mat gray = values;
  if (image.channels == 3) cv::cvtColor(values, gray, cv::COLOR_RGB2GRAY);
  return std::vector<unsigned char>(gray.datastart, gray.dataend);
}

Flow estimate_flow(const Image& from, const Image& to, FlowMethod method) {
  if (from.width != to.width || from.height != to.height)
    fail("optical flow: images differ in size ({}x{} and {}x{})", from.width, from.height, to.width,
         to.height);
  if (from.width < 2 || from.height < 2)
    fail("optical flow: image of {}x{} is too small", from.width, from.height);
  const cv::Mat a = estimator_input(from, method), b = estimator_input(to, method);
  cv::Mat uv;
  make_estimator(method)->calc(a, b, uv);
  return from_mat(uv);
}

FlowErrors flow_errors(const Flow& flow, const Flow& truth,
                       const std::vector<unsigned char>& mask) {
  constexpr double kOutlierPixels = 3, kOutlierFraction = 0.05;  // KITTI 2015's Fl
  if (flow.width != truth.width || flow.height != truth.height || mask.size() != truth.pixels())
    fail("flow errors: flow {}x{}, truth {}x{} and mask of {} pixels differ", flow.width,
         flow.height, truth.width, truth.height, mask.size());
  FlowErrors e;
  for (std::size_t i = 0; i < truth.pixels(); ++i) {
    if (!mask[i]) continue;
    const double tu = truth.uv[2 * i], tv = truth.uv[2 * i + 1];
    const double error = std::hypot(flow.uv[2 * i] - tu, flow.uv[2 * i + 1] - tv);
    e.epe += error;
    e.outliers += error > kOutlierPixels && error > kOutlierFraction * std::hypot(tu, tv);
    ++e.pixels;
  }
  if (e.pixels) e.epe /= double(e.pixels), e.outliers /= double(e.pixels);
  return e;
}

std::size_t mark_inconsistent(Flow& forward, const Flow& backward,
                              const ConsistencyOptions& options) {
  if (forward.width != backward.width || forward.height != backward.height)
    fail("consistency check: forward flow is {}x{} but backward flow is {}x{}", forward.width,
         forward.height, backward.width, backward.height);
  const int w = forward.width, h = forward.height;
  std::size_t marked = 0;
#pragma omp parallel for reduction(+ : marked) schedule(static)
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::size_t p = std::size_t(y) * w + x;
      if (!forward.valid[p]) continue;
      const double fu = forward.uv[2 * p], fv = forward.uv[2 * p + 1];
      const double tu = x + 0.5 + fu, tv = y + 0.5 + fv;  // where x lands in the other frame
      double bu = 0, bv = 0;
      bool ok = tu >= 0 && tv >= 0 && tu < w && tv < h && sample_flow(backward, tu, tv, bu, bv);
      if (ok) {
        const double round_trip = (fu + bu) * (fu + bu) + (fv + bv) * (fv + bv);
        const double magnitude = fu * fu + fv * fv + bu * bu + bv * bv;
        ok = round_trip < options.alpha1 * magnitude + options.alpha2;
      }
      if (!ok) {
        forward.valid[p] = 0;
        forward.uv[2 * p] = forward.uv[2 * p + 1] = 0;
        ++marked;
      }
    }
  return marked;
}

FlowPair estimate_flow_pair(const Image& a, const Image& b, FlowMethod method,
                            const ConsistencyOptions& options) {
  FlowPair pair{estimate_flow(a, b, method), estimate_flow(b, a, method)};
  const Flow raw_forward = pair.forward;
  mark_inconsistent(pair.forward, pair.backward, options);
  mark_inconsistent(pair.backward, raw_forward, options);
  return pair;
}

}  // namespace retimegs::prepare
