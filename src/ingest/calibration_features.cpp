// Static and moving SIFT features of a camera and their matches (calibration_features.hpp).
#include "calibration_features.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"

namespace retimegs::ingest::detail {
namespace {

constexpr int kDescriptorSize = 128;
// A pixel moves at an instant where its grey level differs from the median over the instants by
// more than this (of the 0-255 range): above the noise and compression of a static background,
// below the contrast of a person against it.
constexpr int kMotionThreshold = 25;
// Specks of changed pixels (noise, flicker) narrower than this are not motion, pixels.
constexpr int kMotionOpening = 5;
// Moving regions grow by this before features are sought in them, pixels: a keypoint on a
// moving edge lies just outside the changed pixels.
constexpr int kMotionDilation = 8;
// OpenCV's SIFT contrast threshold: below its default (0.04), as COLMAP's peak threshold is here
// (colmap::ColmapOptions), so that faint walls and floors give features too.
constexpr double kContrastThreshold = 0.02;
// Lowe's ratio test, COLMAP's default (--SiftMatching.max_ratio).
constexpr float kMaxRatio = 0.8f;

cv::Mat grey_u8(const Image& image) {
  cv::Mat out(image.height, image.width, CV_8U);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const float* p = image.pixel(y, x);
      const float g = image.channels >= 3 ? 0.299f * p[0] + 0.587f * p[1] + 0.114f * p[2] : p[0];
      out.at<std::uint8_t>(y, x) = cv::saturate_cast<std::uint8_t>(std::lround(255.0f * g));
    }
  return out;
}

cv::Mat median_of(const std::vector<cv::Mat>& frames) {
  cv::Mat out(frames[0].size(), CV_8U);
  std::vector<std::uint8_t> values(frames.size());
  for (int y = 0; y < out.rows; ++y)
    for (int x = 0; x < out.cols; ++x) {
      for (std::size_t k = 0; k < frames.size(); ++k) values[k] = frames[k].at<std::uint8_t>(y, x);
      std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
      out.at<std::uint8_t>(y, x) = values[values.size() / 2];
    }
  return out;
}

cv::Mat motion_mask(const cv::Mat& frame, const cv::Mat& median) {
  cv::Mat diff, mask;
  cv::absdiff(frame, median, diff);
  mask = diff > kMotionThreshold;
  cv::morphologyEx(mask, mask, cv::MORPH_OPEN,
                   cv::getStructuringElement(cv::MORPH_ELLIPSE, {kMotionOpening, kMotionOpening}));
  const int d = 2 * kMotionDilation + 1;
  cv::dilate(mask, mask, cv::getStructuringElement(cv::MORPH_ELLIPSE, {d, d}));
  return mask;
}

void add_features(cv::SIFT& sift, const cv::Mat& image, const cv::Mat& mask, int instant,
                  CameraFeatures& out) {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  sift.detectAndCompute(image, mask, keypoints, descriptors);
  for (std::size_t i = 0; i < keypoints.size(); ++i) {
    const cv::KeyPoint& k = keypoints[i];
    // OpenCV puts the top-left pixel's centre at (0, 0), COLMAP at (0.5, 0.5); OpenCV's size is a
    // diameter, COLMAP's scale a radius.
    out.features.push_back(
        {k.pt.x + 0.5f, k.pt.y + 0.5f, 0.5f * k.size, float(k.angle * CV_PI / 180.0), instant});
    // OpenCV's SIFT descriptors are already scaled to 0..255.
    for (int j = 0; j < kDescriptorSize; ++j)
      out.descriptors.push_back(
          cv::saturate_cast<std::uint8_t>(std::lround(descriptors.at<float>(int(i), j))));
  }
}

// The descriptors of the features with index in `which`, as OpenCV's matcher takes them.
cv::Mat descriptor_rows(const CameraFeatures& f, const std::vector<int>& which) {
  cv::Mat out(int(which.size()), kDescriptorSize, CV_32F);
  for (std::size_t i = 0; i < which.size(); ++i)
    for (int j = 0; j < kDescriptorSize; ++j)
      out.at<float>(int(i), j) = f.descriptors[std::size_t(which[i]) * kDescriptorSize + j];
  return out;
}

void match_group(const CameraFeatures& a, const CameraFeatures& b, int instant, Matches& out) {
  std::vector<int> ia, ib;
  for (std::size_t i = 0; i < a.features.size(); ++i)
    if (a.features[i].instant == instant) ia.push_back(int(i));
  for (std::size_t i = 0; i < b.features.size(); ++i)
    if (b.features[i].instant == instant) ib.push_back(int(i));
  if (ia.size() < 2 || ib.size() < 2) return;  // the ratio test needs two neighbours
  const cv::Mat da = descriptor_rows(a, ia), db = descriptor_rows(b, ib);
  cv::BFMatcher matcher(cv::NORM_L2);
  std::vector<std::vector<cv::DMatch>> ab, ba;
  matcher.knnMatch(da, db, ab, 2);
  matcher.knnMatch(db, da, ba, 2);
  auto passes = [](const std::vector<cv::DMatch>& m) {
    return m.size() == 2 && m[0].distance <= kMaxRatio * m[1].distance;
  };
  for (const auto& m : ab) {
    if (!passes(m)) continue;
    const auto& back = ba[m[0].trainIdx];
    if (!passes(back) || back[0].trainIdx != m[0].queryIdx) continue;
    out.emplace_back(ia[m[0].queryIdx], ib[m[0].trainIdx]);
  }
}

}  // namespace

CameraFeatures camera_features(int instants, const std::function<Image(int)>& frame,
                               int max_features) {
  if (instants < 3) fail("camera_features: {} instants, a median needs at least 3", instants);
  std::vector<cv::Mat> frames;
  for (int k = 0; k < instants; ++k) {
    frames.push_back(grey_u8(frame(k)));
    if (frames.back().size() != frames.front().size())
      fail("camera_features: instant {} is {}x{}, instant 0 {}x{}", k, frames.back().cols,
           frames.back().rows, frames.front().cols, frames.front().rows);
  }
  const cv::Mat median = median_of(frames);
  cv::Ptr<cv::SIFT> sift = cv::SIFT::create(max_features, 3, kContrastThreshold);
  CameraFeatures out;
  add_features(*sift, median, cv::Mat(), kStaticInstant, out);
  for (std::size_t k = 0; k < frames.size(); ++k)
    add_features(*sift, frames[k], motion_mask(frames[k], median), int(k), out);
  for (const Feature& f : out.features) out.moving += f.instant != kStaticInstant;
  return out;
}

Matches match_features(const CameraFeatures& a, const CameraFeatures& b, bool moving, bool still) {
  int instants = 0;
  for (const Feature& f : a.features) instants = std::max(instants, f.instant + 1);
  Matches out;
  if (still) match_group(a, b, kStaticInstant, out);
  if (moving)
    for (int k = 0; k < instants; ++k) match_group(a, b, k, out);
  return out;
}

void write_colmap_features(const CameraFeatures& f, const std::filesystem::path& file) {
  std::string text = fmt::format("{} {}\n", f.features.size(), kDescriptorSize);
  for (std::size_t i = 0; i < f.features.size(); ++i) {
    const Feature& p = f.features[i];
    text += fmt::format("{} {} {} {}", p.x, p.y, p.scale, p.orientation);
    for (int j = 0; j < kDescriptorSize; ++j)
      text += fmt::format(" {}", int(f.descriptors[i * kDescriptorSize + j]));
    text += '\n';
  }
  write_text_file(file, text);
}

Eigen::Matrix3d fundamental_matrix(const Eigen::Matrix3d& k_a, const Eigen::Matrix4d& pose_a,
                                   const Eigen::Matrix3d& k_b, const Eigen::Matrix4d& pose_b) {
  const Eigen::Matrix4d a_to_b = pose_b * pose_a.inverse();
  const Eigen::Matrix3d r = a_to_b.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = a_to_b.topRightCorner<3, 1>();
  Eigen::Matrix3d tx;
  tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  return k_b.inverse().transpose() * tx * r * k_a.inverse();
}

double epipolar_distance(const Eigen::Matrix3d& fundamental, const Feature& a, const Feature& b) {
  const Eigen::Vector3d line = fundamental * Eigen::Vector3d(a.x, a.y, 1);
  return std::abs(line.dot(Eigen::Vector3d(b.x, b.y, 1))) / std::hypot(line.x(), line.y());
}

std::vector<Matches> agreeing_matches(const std::vector<std::optional<Placement>>& placed,
                                      const std::vector<CameraFeatures>& features,
                                      const std::vector<Matches>& candidates, double tolerance) {
  std::vector<Matches> kept(candidates.size());
  std::size_t pair = 0;
  for (std::size_t a = 0; a < placed.size(); ++a)
    for (std::size_t b = a + 1; b < placed.size(); ++b, ++pair) {
      if (!placed[a] || !placed[b]) continue;
      const Placement &pa = *placed[a], &pb = *placed[b];
      const Eigen::Matrix3d f =
          fundamental_matrix(pa.k, pa.world_to_camera, pb.k, pb.world_to_camera);
      const double limit = tolerance * std::max(pa.larger_side, pb.larger_side);
      for (const auto& [i, j] : candidates.at(pair))
        if (epipolar_distance(f, features[a].features[i], features[b].features[j]) < limit)
          kept[pair].emplace_back(i, j);
    }
  return kept;
}

}  // namespace retimegs::ingest::detail
