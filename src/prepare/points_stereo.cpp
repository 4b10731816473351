// Dense points from rectified camera pairs (the recipe is in points_stereo.hpp).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <utility>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/media/scene_images.hpp"
#include "retimegs/prepare/points_stereo.hpp"
#include "stereo_detail.hpp"

namespace retimegs::prepare {

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

// StereoSGBM's matching window (pixels, odd) and its smoothness penalties for a disparity change
// of one and of more (OpenCV's documented choice: 8 and 32 x channels x window area).
constexpr int kBlockSize = 5;
constexpr int kSmallJumpPenalty = 8 * 3 * kBlockSize * kBlockSize;
constexpr int kLargeJumpPenalty = 32 * 3 * kBlockSize * kBlockSize;
// A best match must beat the second best by this margin in per cent (OpenCV suggests 5-15).
constexpr int kUniquenessRatio = 10;
// Connected disparity blobs of fewer pixels than this, varying by more than kSpeckleRange within,
// are noise (OpenCV suggests 50-200 and 1-2).
constexpr int kSpeckleWindow = 100;
constexpr int kSpeckleRange = 2;
// Left-right check: the right view's disparity at the match within this many pixels.
constexpr double kLeftRightTolerance = 1.0;
// A rectified view whose image border rays are this close to perpendicular to the common optical
// axis (cosine) would stretch without bound: such a pair is skipped.
constexpr double kMinBorderCosine = 0.2;
// The rectified images are at most this many times the pixels of the larger view.
constexpr double kMaxRectifiedAreaRatio = 4;
// A point must project within this share of the image width (and at least 2 pixels) of the
// foreground of every mask of the rig's cameras that sees it: a mismatch off the subject in one
// pair is seen against the background by another camera.
constexpr double kMaskReachFraction = 0.005;
// Fusion's first voxel: one matched pixel's footprint at the scene centre; each pass coarsens it
// by this factor until the cap holds.
constexpr double kVoxelGrowth = 1.25;

// A view ready to match: the image (RGB, [0, 1]) at the matching resolution, its camera at that
// resolution, the mask when the view has one.
struct View {
  Camera camera;
  cv::Mat image;  // CV_32FC3
  cv::Mat mask;   // CV_8U, 255 foreground; empty when the view has no mask
};

cv::Mat to_mat(const Image& image) {
  cv::Mat m(image.height, image.width, CV_MAKETYPE(CV_32F, image.channels));
  std::copy(image.data.begin(), image.data.end(), m.ptr<float>());
  return m;
}

View load_view(const io::Scene& scene, int camera, int frame, double scale) {
  View v;
  const Camera& cam = scene.cameras[camera];
  const int w = std::max(1, int(std::lround(scale * cam.width)));
  const int h = std::max(1, int(std::lround(scale * cam.height)));
  v.camera = resized(cam, w, h);
  cv::Mat image = to_mat(media::load_image(scene, camera, frame));
  if (image.channels() == 1) cv::cvtColor(image, image, cv::COLOR_GRAY2RGB);
  if (w != cam.width || h != cam.height)
    cv::resize(image, image, cv::Size(w, h), 0, 0, cv::INTER_AREA);
  v.image = image;
  if (const std::optional<Image> mask = media::load_mask(scene, camera, frame)) {
    cv::Mat m = to_mat(*mask);
    if (w != cam.width || h != cam.height) cv::resize(m, m, cv::Size(w, h), 0, 0, cv::INTER_AREA);
    v.mask = m > 0.5f;
  }
  return v;
}

// OpenCV's camera matrix (pixel centres at integer coordinates: cx - 0.5, cy - 0.5).
cv::Matx33d opencv_matrix(double fx, double fy, double cx, double cy) {
  return {fx, 0, cx - 0.5, 0, fy, cy - 0.5, 0, 0, 1};
}

// Both views rectified to one rotation whose x axis is the baseline (rows are epipolar lines) and
// one camera matrix: focal length f, principal point (cx, cy) in the project's convention.
struct Rectification {
  Matrix3d rotation;  // world to rectified camera
  double f = 0, cx = 0, cy = 0;
  int width = 0, height = 0;
  double baseline = 0;
};

// Range of the normalised rectified coordinates (x / z, y / z) of a view's image border; false
// when a border ray turns too far from the common axis.
bool border_range(const Camera& cam, const Matrix3d& rectified, Eigen::Vector2d& lo,
                  Eigen::Vector2d& hi) {
  constexpr int kSteps = 16;  // per side
  lo = Eigen::Vector2d::Constant(1e300), hi = -lo;
  const Matrix3d to_rect = rectified * cam.rotation().transpose();
  for (int i = 0; i <= kSteps; ++i)
    for (int side = 0; side < 4; ++side) {
      const double t = double(i) / kSteps;
      const double u = side < 2 ? t * cam.width : (side == 2 ? 0.0 : double(cam.width));
      const double v = side < 2 ? (side == 0 ? 0.0 : double(cam.height)) : t * cam.height;
      const Vector3d r = to_rect * Vector3d((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1);
      if (r.z() < kMinBorderCosine * r.norm()) return false;
      const Eigen::Vector2d n(r.x() / r.z(), r.y() / r.z());
      lo = lo.cwiseMin(n), hi = hi.cwiseMax(n);
    }
  return true;
}

std::optional<Rectification> rectify(const Camera& left, const Camera& right) {
  Rectification r;
  const Vector3d x = right.center() - left.center();
  r.baseline = x.norm();
  const Vector3d axes = left.rotation().row(2).transpose() + right.rotation().row(2).transpose();
  const Vector3d y = axes.cross(x).normalized();
  const Vector3d z = x.normalized().cross(y);
  r.rotation.row(0) = x.normalized().transpose();
  r.rotation.row(1) = y.transpose();
  r.rotation.row(2) = z.transpose();
  Eigen::Vector2d lo_l, hi_l, lo_r, hi_r;
  if (!border_range(left, r.rotation, lo_l, hi_l) || !border_range(right, r.rotation, lo_r, hi_r))
    return std::nullopt;
  // Columns: what either view sees (a left pixel's match lies left of it); rows: both.
  const double x0 = std::min(lo_l.x(), lo_r.x()), x1 = std::max(hi_l.x(), hi_r.x());
  const double y0 = std::max(lo_l.y(), lo_r.y()), y1 = std::min(hi_l.y(), hi_r.y());
  if (y1 <= y0) return std::nullopt;
  r.f = 0.25 * (left.fx + left.fy + right.fx + right.fy);
  r.width = int(std::ceil(r.f * (x1 - x0)));
  r.height = int(std::ceil(r.f * (y1 - y0)));
  const double most =
      std::max(double(left.width) * left.height, double(right.width) * right.height);
  if (double(r.width) * r.height > kMaxRectifiedAreaRatio * most) return std::nullopt;
  r.cx = -r.f * x0;
  r.cy = -r.f * y0;
  return r;
}

// One view resampled into the rectified camera: image, coverage (255 where the view has a pixel),
// mask (when the view has one).
struct RectifiedView {
  cv::Mat image, coverage, mask;
};

RectifiedView resample(const View& view, const Rectification& r) {
  const Camera& cam = view.camera;
  const cv::Matx33d k = opencv_matrix(cam.fx, cam.fy, cam.cx, cam.cy);
  const cv::Matx33d k_new = opencv_matrix(r.f, r.f, r.cx, r.cy);
  const Matrix3d to_rect = r.rotation * cam.rotation().transpose();
  cv::Matx33d rotation;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) rotation(i, j) = to_rect(i, j);
  cv::Mat map_x, map_y;
  cv::initUndistortRectifyMap(k, cv::noArray(), rotation, k_new, cv::Size(r.width, r.height),
                              CV_32FC1, map_x, map_y);
  RectifiedView out;
  cv::remap(view.image, out.image, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  const cv::Mat ones(view.image.size(), CV_8U, cv::Scalar(255));
  cv::remap(ones, out.coverage, map_x, map_y, cv::INTER_NEAREST, cv::BORDER_CONSTANT);
  if (!view.mask.empty())
    cv::remap(view.mask, out.mask, map_x, map_y, cv::INTER_NEAREST, cv::BORDER_CONSTANT);
  return out;
}

cv::Mat to_8bit(const cv::Mat& image) {
  cv::Mat out;
  image.convertTo(out, CV_8UC3, 255.0);
  return out;
}

// World points with colours, [N, 3] each.
struct Points {
  std::vector<Vector3d> xyz, rgb;
};

// The consistent pixels of one pair, appended to `out`.
void match_pair(const io::Scene& scene, const StereoPair& pair, const Vector3d& centre, int frame,
                const StereoOptions& options, Points& out, double& footprint) {
  const Camera& left0 = scene.cameras[pair.left];
  const Camera& right0 = scene.cameras[pair.right];
  // Depths searched, and the matching scale that keeps their disparities within the cap.
  const double distance = (left0.center() - centre).norm();
  const double near = kStereoNearFraction * distance, far = kStereoFarFraction * distance;
  const double baseline = (right0.center() - left0.center()).norm();
  const double f0 = 0.25 * (left0.fx + left0.fy + right0.fx + right0.fy);
  const double span = f0 * baseline * (1 / near - 1 / far);
  const double scale = std::min(1.0, (options.max_disparities - 16) / span);

  const View left = load_view(scene, pair.left, frame, scale);
  const View right = load_view(scene, pair.right, frame, scale);
  const std::optional<Rectification> r = rectify(left.camera, right.camera);
  if (!r) return;
  const RectifiedView rl = resample(left, *r), rr = resample(right, *r);

  const int min_disparity = int(std::floor(r->f * r->baseline / far));
  const int max_disparity = int(std::ceil(r->f * r->baseline / near));
  const int count = std::min(options.max_disparities,
                             std::max(16, (max_disparity - min_disparity + 15) / 16 * 16));
  cv::Ptr<cv::StereoSGBM> sgbm =
      cv::StereoSGBM::create(min_disparity, count, kBlockSize, kSmallJumpPenalty, kLargeJumpPenalty,
                             /*disp12MaxDiff=*/-1, /*preFilterCap=*/63, kUniquenessRatio,
                             kSpeckleWindow, kSpeckleRange, cv::StereoSGBM::MODE_SGBM_3WAY);
  const cv::Mat l8 = to_8bit(rl.image), r8 = to_8bit(rr.image);
  cv::Mat left_disparity, right_disparity, l_flip, r_flip;
  sgbm->compute(l8, r8, left_disparity);
  // The right view's disparities: the mirrored right image matched against the mirrored left one
  // (right pixel x matches left pixel x + d).
  cv::flip(l8, l_flip, 1);
  cv::flip(r8, r_flip, 1);
  sgbm->compute(r_flip, l_flip, right_disparity);
  cv::flip(right_disparity, right_disparity, 1);

  const Matrix3d to_world = r->rotation.transpose();
  const Vector3d origin = left.camera.center();
  footprint = std::min(footprint, distance / r->f);
  const int lowest = 16 * min_disparity, highest = 16 * (min_disparity + count);
  for (int y = 0; y < r->height; ++y)
    for (int x = 0; x < r->width; ++x) {
      const int dl = left_disparity.at<std::int16_t>(y, x);
      if (dl < lowest || dl >= highest || !rl.coverage.at<unsigned char>(y, x)) continue;
      if (!rl.mask.empty() && !rl.mask.at<unsigned char>(y, x)) continue;
      const double d = dl / 16.0;
      const int xr = int(std::lround(x - d));
      if (xr < 0 || xr >= r->width || !rr.coverage.at<unsigned char>(y, xr)) continue;
      const int dr = right_disparity.at<std::int16_t>(y, xr);
      if (dr < lowest || dr >= highest || std::abs(dr / 16.0 - d) > kLeftRightTolerance) continue;
      const double z = r->f * r->baseline / d;
      if (z < near || z > far) continue;
      // Pixel centres are at integer coordinates of OpenCV's matrix: (x + 0.5) here.
      const Vector3d p((x + 0.5 - r->cx) / r->f * z, (y + 0.5 - r->cy) / r->f * z, z);
      out.xyz.push_back(origin + to_world * p);
      const cv::Vec3f c = rl.image.at<cv::Vec3f>(y, x);
      out.rgb.emplace_back(c[0], c[1], c[2]);
    }
}

// The points that every camera of `cameras` with a mask at `frame` and the point in its image
// sees within reach of its foreground.
Points inside_every_mask(const io::Scene& scene, const std::vector<int>& cameras, int frame,
                         Points in) {
  for (int c : cameras) {
    const std::optional<Image> mask = media::load_mask(scene, c, frame);
    if (!mask) continue;
    cv::Mat background(mask->height, mask->width, CV_8U);
    for (int y = 0; y < mask->height; ++y)
      for (int x = 0; x < mask->width; ++x)
        background.at<unsigned char>(y, x) = mask->at(y, x) > 0.5f ? 0 : 255;
    cv::Mat distance;
    cv::distanceTransform(background, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    const Camera& cam = scene.cameras[c];
    const double reach = std::max(2.0, kMaskReachFraction * cam.width);
    Points kept;
    for (std::size_t i = 0; i < in.xyz.size(); ++i) {
      const Vector3d xc = cam.world_to_cam(in.xyz[i]);
      if (xc.z() > 0) {
        const Eigen::Vector2d uv = cam.project_cam(xc);
        if (cam.in_image(uv) && distance.at<float>(int(uv.y()), int(uv.x())) > reach) continue;
      }
      kept.xyz.push_back(in.xyz[i]);
      kept.rgb.push_back(in.rgb[i]);
    }
    in = std::move(kept);
  }
  return in;
}

// Points averaged per voxel of size `voxel`, in voxel order.
Points voxel_average(const Points& in, double voxel) {
  Vector3d lo = Vector3d::Constant(1e300);
  for (const Vector3d& p : in.xyz) lo = lo.cwiseMin(p);
  std::vector<std::pair<std::uint64_t, std::size_t>> keys(in.xyz.size());
  for (std::size_t i = 0; i < in.xyz.size(); ++i) {
    const Eigen::Array3d q = ((in.xyz[i] - lo) / voxel).array().floor();
    keys[i] = {(std::uint64_t(q.x()) << 42) | (std::uint64_t(q.y()) << 21) | std::uint64_t(q.z()),
               i};
  }
  std::sort(keys.begin(), keys.end());
  Points out;
  for (std::size_t i = 0; i < keys.size();) {
    std::size_t j = i;
    Vector3d xyz = Vector3d::Zero(), rgb = Vector3d::Zero();
    for (; j < keys.size() && keys[j].first == keys[i].first; ++j)
      xyz += in.xyz[keys[j].second], rgb += in.rgb[keys[j].second];
    out.xyz.push_back(xyz / double(j - i));
    out.rgb.push_back(rgb / double(j - i));
    i = j;
  }
  return out;
}

}  // namespace

io::PointCloud stereo_points(const io::Scene& scene, const std::vector<int>& cameras, int frame,
                             const StereoOptions& options) {
  if (options.max_disparities < 32 || options.max_disparities % 16)
    fail("pair stereo: max_disparities must be a multiple of 16 and >= 32, got {}",
         options.max_disparities);
  if (options.max_points == 0) fail("pair stereo: max_points must be > 0");
  const std::vector<StereoPair> pairs = stereo_pairs(scene, cameras);
  if (pairs.empty())
    fail(
        "pair stereo: no usable pair among the {} training cameras (a pair needs optical axes "
        "within {} degrees of each other and a triangulation angle of {} degrees or more at the "
        "scene centre)",
        cameras.size(), kMaxStereoAxisAngle, kMinStereoTriangulationAngle);
  const Vector3d centre = detail::scene_centre(scene, cameras);
  Points all;
  double footprint = std::numeric_limits<double>::infinity();
  for (const StereoPair& pair : pairs)
    match_pair(scene, pair, centre, frame, options, all, footprint);
  all = inside_every_mask(scene, cameras, frame, std::move(all));
  if (all.xyz.empty())
    fail("pair stereo at frame {}: the {} usable pair{} matched no pixel consistently", frame,
         pairs.size(), pairs.size() == 1 ? "" : "s");

  // Voxels of at least the extent / 2^21 (the key's 21 bits per axis).
  Vector3d lo = Vector3d::Constant(1e300), hi = -lo;
  for (const Vector3d& p : all.xyz) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  double voxel = std::max(footprint, (hi - lo).maxCoeff() / double((1 << 21) - 2));
  Points fused = voxel_average(all, voxel);
  while (fused.xyz.size() > options.max_points) {
    voxel *= kVoxelGrowth;
    fused = voxel_average(all, voxel);
  }
  io::PointCloud cloud;
  for (std::size_t i = 0; i < fused.xyz.size(); ++i)
    for (int a = 0; a < 3; ++a) {
      cloud.xyz.push_back(float(fused.xyz[i][a]));
      cloud.rgb.push_back(float(std::clamp(fused.rgb[i][a], 0.0, 1.0)));
    }
  return cloud;
}

}  // namespace retimegs::prepare
