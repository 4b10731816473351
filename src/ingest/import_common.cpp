// Helpers shared by the importers (import_common.hpp).
#include "import_common.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/core/progress.hpp"

namespace retimegs::ingest::detail {

double finite_number(const nlohmann::json& v, const std::string& file, const std::string& field) {
  if (!v.is_number() || !std::isfinite(v.get<double>()))
    fail("{}: '{}' must be a finite number, got {}", file, field, v.dump());
  return v.get<double>();
}

std::pair<int, int> frame_range(const ImportOptions& options, int steps, const std::string& what) {
  const int first = options.first_frame;
  const int last = options.last_frame < 0 ? steps - 1 : options.last_frame;
  if (first < 0 || last >= steps || first > last)
    fail("--frames: {}:{} is outside the frames 0:{} of {}", first, last, steps - 1, what);
  return {first, last};
}

Image from_bgr8(const cv::Mat& mat) {
  cv::Mat rgb;
  if (mat.channels() == 1)
    cv::cvtColor(mat, rgb, cv::COLOR_GRAY2RGB);
  else if (mat.channels() == 4)
    cv::cvtColor(mat, rgb, cv::COLOR_BGRA2RGB);
  else
    cv::cvtColor(mat, rgb, cv::COLOR_BGR2RGB);
  Image out(rgb.cols, rgb.rows, 3);
  cv::Mat dst(rgb.rows, rgb.cols, CV_32FC3, out.data.data());
  rgb.convertTo(dst, CV_32F, 1.0 / 255.0);
  return out;
}

// ---------------------------------------------------------------------------------------------
// Undistortion

namespace {

bool is_pinhole(const std::string& model) {
  return model == "SIMPLE_PINHOLE" || model == "PINHOLE";
}

}  // namespace

Undistorter::Undistorter(const io::ColmapCamera& source, const std::string& what)
    : source_(source) {
  const std::string& m = source.model;
  const int n = io::colmap_model_num_params(m);
  static const char* kSupported =
      "SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV, OPENCV_FISHEYE";
  if (n < 0 || !(is_pinhole(m) || m == "SIMPLE_RADIAL" || m == "RADIAL" || m == "OPENCV" ||
                 m == "FULL_OPENCV" || m == "OPENCV_FISHEYE"))
    fail("{}: camera model {} is not supported (supported: {})", what, m, kSupported);
  if (int(source.params.size()) != n)
    fail("{}: camera model {} needs {} parameters, got {}", what, m, n, source.params.size());
  for (std::size_t i = 0; i < source.params.size(); ++i)
    if (!std::isfinite(source.params[i])) fail("{}: camera parameter {} is not finite", what, i);
  if (source.width < 1 || source.height < 1)
    fail("{}: camera size {}x{} is not positive", what, source.width, source.height);
  const auto& p = source.params;
  const bool simple = m == "SIMPLE_PINHOLE" || m == "SIMPLE_RADIAL" || m == "RADIAL";
  pinhole_.width = source.width, pinhole_.height = source.height;
  pinhole_.fx = p[0];
  pinhole_.fy = simple ? p[0] : p[1];
  pinhole_.cx = simple ? p[1] : p[2];
  pinhole_.cy = simple ? p[2] : p[3];
  if (!(pinhole_.fx > 0 && pinhole_.fy > 0))
    fail("{}: focal length must be positive, got {} {}", what, pinhole_.fx, pinhole_.fy);
  // Zero coefficients leave a pinhole, except for OPENCV_FISHEYE: its projection is equidistant
  // (radius proportional to the angle) even then.
  identity_ = m != "OPENCV_FISHEYE";
  for (std::size_t i = simple ? 3 : 4; i < p.size(); ++i) identity_ &= p[i] == 0.0;
  if (identity_) return;

  // Smallest focal scale s (widest view) for which every border pixel of the output samples
  // inside the source image: alpha 0 of cv::getOptimalNewCameraMatrix, principal point kept.
  const int w = source.width, h = source.height;
  auto all_inside = [&](double s) {
    auto inside = [&](double u, double v) {
      const Eigen::Vector2d q = distort_project((u - pinhole_.cx) / (s * pinhole_.fx),
                                                (v - pinhole_.cy) / (s * pinhole_.fy));
      return std::isfinite(q.x()) && std::isfinite(q.y()) && q.x() >= 0 && q.y() >= 0 &&
             q.x() <= w && q.y() <= h;
    };
    for (int x = 0; x < w; ++x)
      if (!inside(x + 0.5, 0.5) || !inside(x + 0.5, h - 0.5)) return false;
    for (int y = 0; y < h; ++y)
      if (!inside(0.5, y + 0.5) || !inside(w - 0.5, y + 0.5)) return false;
    return true;
  };
  // Lower bound 0.5: at most twice the field of view of the same pinhole, which also keeps the
  // search away from where strong barrel distortion folds back on itself.
  double lo = 0.5, hi = 1.0;
  while (!all_inside(hi)) {
    lo = hi, hi *= 2;
    if (hi > 64)
      fail("{}: distortion too strong to undistort (parameters {})", what, fmt::join(p, ", "));
  }
  if (all_inside(lo)) hi = lo;
  for (int it = 0; it < 40 && hi - lo > 1e-7; ++it) {
    const double mid = 0.5 * (lo + hi);
    (all_inside(mid) ? hi : lo) = mid;
  }
  pinhole_.fx *= hi, pinhole_.fy *= hi;

  map_x_.create(h, w, CV_32F);
  map_y_.create(h, w, CV_32F);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Eigen::Vector2d q = distort_project((x + 0.5 - pinhole_.cx) / pinhole_.fx,
                                                (y + 0.5 - pinhole_.cy) / pinhole_.fy);
      map_x_.at<float>(y, x) = float(q.x() - 0.5);  // OpenCV: pixel centres at integers
      map_y_.at<float>(y, x) = float(q.y() - 0.5);
    }
}

Eigen::Vector2d Undistorter::distort_project(double x, double y) const {
  const std::string& m = source_.model;
  const auto& p = source_.params;
  const bool simple = m == "SIMPLE_PINHOLE" || m == "SIMPLE_RADIAL" || m == "RADIAL";
  const double fx = p[0], fy = simple ? p[0] : p[1];
  const double cx = simple ? p[1] : p[2], cy = simple ? p[2] : p[3];
  const double r2 = x * x + y * y;
  double xd = x, yd = y;
  if (m == "SIMPLE_RADIAL" || m == "RADIAL") {
    const double radial = p[3] * r2 + (m == "RADIAL" ? p[4] * r2 * r2 : 0.0);
    xd = x + x * radial, yd = y + y * radial;
  } else if (m == "OPENCV" || m == "FULL_OPENCV") {
    const double k1 = p[4], k2 = p[5], p1 = p[6], p2 = p[7];
    double radial = 1 + k1 * r2 + k2 * r2 * r2;
    if (m == "FULL_OPENCV")
      radial =
          (radial + p[8] * r2 * r2 * r2) / (1 + p[9] * r2 + p[10] * r2 * r2 + p[11] * r2 * r2 * r2);
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
    yd = y * radial + 2 * p2 * x * y + p1 * (r2 + 2 * y * y);
  } else if (m == "OPENCV_FISHEYE") {
    const double r = std::sqrt(r2);
    if (r > 1e-12) {
      const double theta = std::atan(r), t2 = theta * theta;
      const double thetad = theta * (1 + t2 * (p[4] + t2 * (p[5] + t2 * (p[6] + t2 * p[7]))));
      xd = x * thetad / r, yd = y * thetad / r;
    }
  }
  return {fx * xd + cx, fy * yd + cy};
}

Image Undistorter::apply(const Image& image) const {
  if (identity_) return image;
  if (image.width != source_.width || image.height != source_.height)
    fail("undistort: image is {}x{} but its camera is {}x{}", image.width, image.height,
         source_.width, source_.height);
  cv::Mat src(image.height, image.width, CV_32FC(image.channels),
              const_cast<float*>(image.data.data()));
  Image out(pinhole_.width, pinhole_.height, image.channels);
  cv::Mat dst(out.height, out.width, CV_32FC(out.channels), out.data.data());
  cv::remap(src, dst, map_x_, map_y_, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

void parallel_jobs(std::size_t count, std::size_t ticks, const std::string& label,
                   bool progress_enabled, const std::function<void(std::size_t, Progress&)>& job) {
  Progress progress(label, ticks, progress_enabled);
  parallel_for(count, [&](std::size_t i) { job(i, progress); });
  progress.finish();
}

Eigen::Vector3d mean_camera_up(const std::vector<Camera>& cameras) {
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  for (const Camera& cam : cameras) up -= cam.rotation().transpose().col(1);
  if (up.norm() < 1e-9) return {0, -1, 0};
  return up.normalized();
}

}  // namespace retimegs::ingest::detail
