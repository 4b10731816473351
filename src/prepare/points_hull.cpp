// Visual hull of the foreground masks at one frame (the recipe is in points.hpp).
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <random>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "look_region.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/media/scene_images.hpp"
#include "retimegs/prepare/points.hpp"

namespace retimegs::prepare {

namespace {

using Eigen::Vector3d;

// Silhouettes that must hold a voxel whatever the slack: one camera's silhouette alone keeps its
// whole viewing cone.
constexpr int kMinInside = 2;
// From this many cameras that see a voxel on, the slack always applies: n - 1 views carve about
// as well as n. Below, where each view carves much that the others do not (8 ring cameras of the
// synthetic scene: with a slack of one, 78 % of the hull's points lie within 3 voxels of the
// surface instead of 97 %), it applies only at a frame whose masks disagree (kAgreeingShare).
constexpr int kSlackMinCameras = 10;
// The masks of a frame agree when the hull carved by every silhouette keeps at least this share
// of the coarse voxels that the hull with the slack keeps. Agreeing masks of 3 to 8 ring cameras
// (synthetic scenes) keep 45 to 86 %; a blank or missing mask keeps nothing, a mask that leaves
// out a person all but that person.
constexpr double kAgreeingShare = 0.25;
// A point is visible in a camera when it is at most this many voxel sizes behind the nearest
// surface point along the ray (the depth map is of the jittered surface points themselves).
constexpr double kVisibilitySlackVoxels = 2.0;

// One camera's view of the frame: its silhouette as a distance map (pixels to the nearest
// foreground pixel, 0 on the foreground) and its image.
struct View {
  const Camera* camera;
  cv::Mat distance;  // CV_32F [H, W]
  Image image;       // RGB [H, W, 3]
};

// A regular grid of cubic voxels: voxel (i, j, k) has its centre at origin + (i, j, k) * size.
struct Grid {
  Vector3d origin;
  double size = 0;
  int nx = 0, ny = 0, nz = 0;
  std::size_t count() const { return std::size_t(nx) * ny * nz; }
  std::size_t index(int i, int j, int k) const { return (std::size_t(k) * ny + j) * nx + i; }
  Vector3d centre(int i, int j, int k) const { return origin + size * Vector3d(i, j, k); }
};

// Grid of `resolution` voxels along the longest side of [lo, hi] (at least 1 along each).
Grid make_grid(const Vector3d& lo, const Vector3d& hi, int resolution) {
  Grid g;
  const Vector3d extent = hi - lo;
  g.size = extent.maxCoeff() / resolution;
  g.nx = std::max(1, int(std::ceil(extent.x() / g.size)));
  g.ny = std::max(1, int(std::ceil(extent.y() / g.size)));
  g.nz = std::max(1, int(std::ceil(extent.z() / g.size)));
  g.origin = lo + 0.5 * g.size * Vector3d::Ones();
  return g;
}

// The carving rule (k-of-n): a voxel in view of `seen` of the cameras and inside `inside` of
// their silhouettes is kept when at least half of the cameras (and at least 2) see it, and it lies
// inside the silhouettes of all of those but k, and of at least kMinInside. k is `slack` where
// kSlackMinCameras or more see the voxel, or where the frame's masks disagree (`tolerant`), else
// 0. With slack 1 and a bad mask: 2 of 2, 2 of 3, 3 of 4, 7 of 8, 29 of 30: one missing or bad
// mask does not empty the hull of a rig of three or more cameras, and two cameras still both
// carve. Cameras that do not see the voxel abstain, so that people cut by the image border of a
// few views survive (Panoptic dome).
struct CarveRule {
  int min_seen = 2;
  int slack = 0;
  bool tolerant = false;
  bool keep(int seen, int inside) const {
    const int k = tolerant || seen >= kSlackMinCameras ? slack : 0;
    return seen >= min_seen && inside >= std::max(kMinInside, seen - k);
  }
};

// Occupancy [nz, ny, nx] under `rule`; a voxel is inside a silhouette when its centre projects
// within `reach` (world units, projected at the voxel's depth) of a foreground pixel.
std::vector<unsigned char> carve(const Grid& g, const std::vector<View>& views,
                                 const CarveRule& rule, double reach) {
  std::vector<unsigned char> occupied(g.count(), 0);
#pragma omp parallel for collapse(2) schedule(static)
  for (int k = 0; k < g.nz; ++k)
    for (int j = 0; j < g.ny; ++j)
      for (int i = 0; i < g.nx; ++i) {
        const Vector3d x = g.centre(i, j, k);
        int seen = 0, inside = 0;
        for (const View& v : views) {
          const Vector3d xc = v.camera->world_to_cam(x);
          if (xc.z() <= reach) continue;
          const Eigen::Vector2d uv = v.camera->project_cam(xc);
          if (!v.camera->in_image(uv)) continue;
          ++seen;
          // Within `reach` of a foreground pixel, plus half a pixel for the pixel's own extent.
          inside +=
              v.distance.at<float>(int(uv.y()), int(uv.x())) <= v.camera->fx * reach / xc.z() + 0.5;
        }
        occupied[g.index(i, j, k)] = rule.keep(seen, inside);
      }
  return occupied;
}

// Bounding box of the occupied voxels (centres), grown by `margin` on every side; false if none.
bool occupied_bounds(const Grid& g, const std::vector<unsigned char>& occupied, double margin,
                     Vector3d& lo, Vector3d& hi) {
  lo = Vector3d::Constant(std::numeric_limits<double>::infinity());
  hi = -lo;
  bool any = false;
  for (int k = 0; k < g.nz; ++k)
    for (int j = 0; j < g.ny; ++j)
      for (int i = 0; i < g.nx; ++i)
        if (occupied[g.index(i, j, k)]) {
          lo = lo.cwiseMin(g.centre(i, j, k));
          hi = hi.cwiseMax(g.centre(i, j, k));
          any = true;
        }
  lo -= Vector3d::Constant(margin);
  hi += Vector3d::Constant(margin);
  return any;
}

// Per-camera depth map of the points: each point covers the pixels within its voxel's projected
// half size (at least the pixel it falls in). [H, W], +inf where empty.
std::vector<float> depth_map(const Camera& cam, const std::vector<Vector3d>& points, double voxel) {
  std::vector<float> depth(std::size_t(cam.width) * cam.height,
                           std::numeric_limits<float>::infinity());
  for (const Vector3d& x : points) {
    const Vector3d xc = cam.world_to_cam(x);
    if (xc.z() <= 0) continue;
    const Eigen::Vector2d uv = cam.project_cam(xc);
    const double r = 0.5 * cam.fx * voxel / xc.z();
    const int x0 = std::max(0, int(std::floor(uv.x() - r))),
              x1 = std::min(cam.width - 1, int(std::floor(uv.x() + r)));
    const int y0 = std::max(0, int(std::floor(uv.y() - r))),
              y1 = std::min(cam.height - 1, int(std::floor(uv.y() + r)));
    for (int y = y0; y <= y1; ++y)
      for (int xx = x0; xx <= x1; ++xx) {
        float& d = depth[std::size_t(y) * cam.width + xx];
        d = std::min(d, float(xc.z()));
      }
  }
  return depth;
}

}  // namespace

io::PointCloud visual_hull(const io::Scene& scene, const std::vector<int>& cameras, int frame,
                           const HullOptions& options) {
  if (options.resolution < 4)
    fail("visual hull: resolution must be >= 4, got {}", options.resolution);
  if (cameras.size() < 2)
    fail("visual hull: needs at least 2 cameras with masks, got {}", cameras.size());
  std::vector<View> views(cameras.size());
  parallel_for(cameras.size(), [&](std::size_t v) {
    const int c = cameras[v];
    const std::optional<Image> mask = media::load_mask(scene, c, frame);
    if (!mask)
      fail("{}: no mask; the visual hull needs the masks of every training camera",
           scene.mask_path(c, frame).string());
    cv::Mat background(mask->height, mask->width, CV_8UC1);
    for (int y = 0; y < mask->height; ++y)
      for (int x = 0; x < mask->width; ++x)
        background.at<unsigned char>(y, x) = mask->at(y, x) > 0.5f ? 0 : 255;
    views[v].camera = &scene.cameras[c];
    cv::distanceTransform(background, views[v].distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    views[v].image = media::load_image(scene, c, frame);
  });
  const int min_seen = std::max(2, (int(views.size()) + 1) / 2);
  const int slack = std::max(0, options.slack);
  const CarveRule strict{min_seen, slack, false}, tolerant{min_seen, slack, true};

  // Coarse pass over the common region, fine pass over the coarse hull's bounds.
  Vector3d lo, hi;
  detail::common_region(scene, cameras, lo, hi);
  const Grid coarse = make_grid(lo, hi, options.resolution);
  // Coarse: conservative (half the voxel's diagonal: the voxel's footprint touches the
  // silhouette), so that thin parts survive voxels larger than they are.
  const double coarse_reach = 0.5 * std::sqrt(3.0) * coarse.size;
  const std::vector<unsigned char> coarse_tolerant = carve(coarse, views, tolerant, coarse_reach);
  std::vector<unsigned char> coarse_occupied = carve(coarse, views, strict, coarse_reach);
  const auto count = [](const std::vector<unsigned char>& v) {
    return std::size_t(std::count(v.begin(), v.end(), 1));
  };
  // Where the masks agree each camera's carving stands; where one mask carved away much of what
  // the others keep (blank, a person left out), the slack keeps what the other views agree on.
  const bool masks_agree =
      double(count(coarse_occupied)) >= kAgreeingShare * double(count(coarse_tolerant));
  const CarveRule& rule = masks_agree ? strict : tolerant;
  if (!masks_agree) coarse_occupied = coarse_tolerant;
  if (!occupied_bounds(coarse, coarse_occupied, coarse.size, lo, hi))
    fail(
        "visual hull at frame {}: empty (no region lies inside the masks of the cameras that see "
        "it)",
        frame);
  const Grid g = make_grid(lo, hi, options.resolution);
  // Fine: half the voxel's side; the diagonal would fatten the hull by most of a voxel (on the
  // 8-camera synthetic scene the 80th percentile distance to the surface grows from 1.7 to 2.8
  // voxels).
  const std::vector<unsigned char> occupied = carve(g, views, rule, 0.5 * g.size);

  // Surface voxels and their outward normals.
  auto at = [&](int i, int j, int k) {
    return i >= 0 && j >= 0 && k >= 0 && i < g.nx && j < g.ny && k < g.nz &&
           occupied[g.index(i, j, k)];
  };
  std::vector<Eigen::Vector3i> surface;
  for (int k = 0; k < g.nz; ++k)
    for (int j = 0; j < g.ny; ++j)
      for (int i = 0; i < g.nx; ++i)
        if (at(i, j, k) && !(at(i - 1, j, k) && at(i + 1, j, k) && at(i, j - 1, k) &&
                             at(i, j + 1, k) && at(i, j, k - 1) && at(i, j, k + 1)))
          surface.emplace_back(i, j, k);
  if (surface.empty()) fail("visual hull at frame {}: empty", frame);

  std::mt19937_64 rng(options.seed ^ (0x9e3779b97f4a7c15ull * std::uint64_t(frame + 1)));
  const std::size_t n = surface.size();
  std::vector<Vector3d> points(n), normals(n);
  std::uniform_real_distribution<double> jitter(-0.5, 0.5);
  for (std::size_t p = 0; p < n; ++p) {
    const Eigen::Vector3i& v = surface[p];
    points[p] =
        g.centre(v.x(), v.y(), v.z()) + g.size * Vector3d(jitter(rng), jitter(rng), jitter(rng));
    // Occupancy gradient over the 3x3x3 neighbourhood points inwards.
    Vector3d gradient = Vector3d::Zero();
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          if (at(v.x() + dx, v.y() + dy, v.z() + dz)) gradient += Vector3d(dx, dy, dz);
    normals[p] = gradient.norm() > 0 ? Vector3d(-gradient.normalized()) : Vector3d::Zero();
  }

  // Colours from the cameras that see each point unoccluded; points no camera sees (under an
  // object, hull volume hidden behind the true surface) are dropped: no view could train them.
  std::vector<std::vector<float>> depth(views.size());
#pragma omp parallel for schedule(dynamic)
  for (std::size_t v = 0; v < views.size(); ++v)
    depth[v] = depth_map(*views[v].camera, points, g.size);
  std::vector<Vector3d> colours(n);
  std::vector<unsigned char> visible(n, 0);
#pragma omp parallel for schedule(static)
  for (std::size_t p = 0; p < n; ++p) {
    Vector3d sum = Vector3d::Zero(), plain = Vector3d::Zero();
    double weight = 0;
    int seen = 0;
    for (std::size_t v = 0; v < views.size(); ++v) {
      const Camera& cam = *views[v].camera;
      const Vector3d xc = cam.world_to_cam(points[p]);
      if (xc.z() <= 0) continue;
      const Eigen::Vector2d uv = cam.project_cam(xc);
      if (!cam.in_image(uv)) continue;
      const float nearest = depth[v][std::size_t(uv.y()) * cam.width + std::size_t(uv.x())];
      if (xc.z() > nearest + kVisibilitySlackVoxels * g.size) continue;
      Vector3d colour;
      for (int ch = 0; ch < 3; ++ch)
        colour[ch] = sample_bilinear(views[v].image, uv.x(), uv.y(), ch);
      const double w = std::max(0.0, normals[p].dot((cam.center() - points[p]).normalized()));
      sum += w * colour;
      weight += w;
      plain += colour;
      ++seen;
    }
    visible[p] = seen > 0;
    colours[p] = weight > 0 ? Vector3d(sum / weight)
                 : seen > 0 ? Vector3d(plain / seen)
                            : Vector3d::Zero();
  }
  std::vector<std::size_t> keep;
  for (std::size_t p = 0; p < n; ++p)
    if (visible[p]) keep.push_back(p);
  if (keep.empty()) fail("visual hull at frame {}: no camera sees its surface", frame);
  if (keep.size() > options.max_points) {
    std::shuffle(keep.begin(), keep.end(), rng);
    keep.resize(options.max_points);
    std::sort(keep.begin(), keep.end());
  }
  io::PointCloud cloud;
  for (std::size_t p : keep)
    for (int a = 0; a < 3; ++a) {
      cloud.xyz.push_back(float(points[p][a]));
      cloud.rgb.push_back(float(std::clamp(colours[p][a], 0.0, 1.0)));
    }
  return cloud;
}

}  // namespace retimegs::prepare
