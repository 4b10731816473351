#include "retimegs/io/coverage.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include <fmt/format.h>

#include "retimegs/core/error.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/io/training_views.hpp"

namespace retimegs::io {
namespace {

constexpr float kEmpty = std::numeric_limits<float>::infinity();

int coverage_radius(const Camera& cam) {
  return std::max(1, int(std::lround(kCoverageRadiusFraction * std::max(cam.width, cam.height))));
}

// The depth (camera z) of the nearest point within coverage_radius() of each pixel; kEmpty where
// there is none. [H, W]
std::vector<float> depth_map(const Camera& cam, const PointCloud& points) {
  std::vector<float> depth(std::size_t(cam.width) * cam.height, kEmpty);
  const int r = coverage_radius(cam);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d xc =
        cam.world_to_cam({points.xyz[3 * i], points.xyz[3 * i + 1], points.xyz[3 * i + 2]});
    if (xc.z() <= 1e-9) continue;
    const Eigen::Vector2d uv = cam.project_cam(xc);
    if (!(uv.x() > -r && uv.y() > -r && uv.x() < cam.width + r && uv.y() < cam.height + r))
      continue;
    const int px = int(std::floor(uv.x())), py = int(std::floor(uv.y()));
    for (int y = std::max(0, py - r); y <= std::min(cam.height - 1, py + r); ++y)
      for (int x = std::max(0, px - r); x <= std::min(cam.width - 1, px + r); ++x) {
        if ((x - px) * (x - px) + (y - py) * (y - py) > r * r) continue;
        float& d = depth[std::size_t(y) * cam.width + x];
        d = std::min(d, float(xc.z()));
      }
  }
  return depth;
}

bool foreground(const Image* mask, std::size_t pixel) {
  return !mask || mask->data[pixel * mask->channels] > 0.5f;
}

// Whether a training camera sees world point x unoccluded by the cloud (its depth map).
bool sees(const Camera& cam, const std::vector<float>& depth, const Eigen::Vector3d& x) {
  const Eigen::Vector3d xc = cam.world_to_cam(x);
  if (xc.z() <= 1e-9) return false;
  const Eigen::Vector2d uv = cam.project_cam(xc);
  if (!cam.in_image(uv)) return false;
  const float nearest = depth[std::size_t(uv.y()) * cam.width + std::size_t(uv.x())];
  return nearest != kEmpty && xc.z() <= nearest * (1 + kCoverageOcclusionTolerance);
}

}  // namespace

CoverageCounter::CoverageCounter(const Scene& scene)
    : scene_(scene), training_(training_cameras(scene)), counts_(scene.cameras.size()) {
  if (training_.empty())
    fail("{}: point coverage: the scene has no training camera", scene.json_path().string());
}

void CoverageCounter::add(const PointCloud& points, const std::vector<const Image*>& masks) {
  const std::size_t n = scene_.cameras.size();
  if (!masks.empty() && masks.size() != n)
    fail("point coverage: {} masks for {} cameras", masks.size(), n);
  const auto mask_of = [&](std::size_t c) { return masks.empty() ? nullptr : masks[c]; };
  for (std::size_t c = 0; c < n; ++c)
    if (const Image* m = mask_of(c);
        m && (m->width != scene_.cameras[c].width || m->height != scene_.cameras[c].height))
      fail("point coverage: camera {}'s mask is {}x{}, the camera {}x{}", scene_.cameras[c].name,
           m->width, m->height, scene_.cameras[c].width, scene_.cameras[c].height);
  std::vector<std::vector<float>> depth(n);
  parallel_for(n, [&](std::size_t c) { depth[c] = depth_map(scene_.cameras[c], points); });
  parallel_for(n, [&](std::size_t c) {
    const Camera& cam = scene_.cameras[c];
    const Image* mask = mask_of(c);
    const bool test = cam.split == Split::kTest;
    Counts& k = counts_[c];
    k.masked = k.masked && mask != nullptr;
    for (int y = 0; y < cam.height; ++y)
      for (int x = 0; x < cam.width; ++x) {
        const std::size_t p = std::size_t(y) * cam.width + x;
        if (!foreground(mask, p)) continue;
        ++k.pixels;
        if (depth[c][p] == kEmpty) continue;
        ++k.covered;
        if (!test) continue;
        const Eigen::Vector3d point = cam.unproject({x + 0.5, y + 0.5}, depth[c][p]);
        if (std::none_of(training_.begin(), training_.end(),
                         [&](int t) { return sees(scene_.cameras[t], depth[t], point); }))
          ++k.unseen;
      }
  });
}

Coverage CoverageCounter::result() const {
  Coverage result;
  std::size_t pixels = 0, covered = 0;
  result.masked = true;
  for (std::size_t c = 0; c < counts_.size(); ++c) {
    const Counts& k = counts_[c];
    CameraCoverage& out = result.cameras.emplace_back();
    out.camera = int(c);
    out.masked = k.masked && k.pixels > 0;
    out.covered = k.pixels ? double(k.covered) / double(k.pixels) : 0;
    if (scene_.cameras[c].split == Split::kTest) {
      out.unseen = k.covered ? double(k.unseen) / double(k.covered) : 0;
    } else {
      pixels += k.pixels, covered += k.covered;
      result.masked = result.masked && out.masked;
    }
  }
  result.training_covered = pixels ? double(covered) / double(pixels) : 0;
  return result;
}

std::vector<std::size_t> coverage_frames(std::size_t count) {
  if (count <= kCoverageFrames) {
    std::vector<std::size_t> all(count);
    for (std::size_t i = 0; i < count; ++i) all[i] = i;
    return all;
  }
  std::vector<std::size_t> spread;
  for (std::size_t j = 0; j < kCoverageFrames; ++j)
    spread.push_back(j * (count - 1) / (kCoverageFrames - 1));
  return spread;
}

std::string describe_coverage(const Scene& scene, const Coverage& coverage) {
  std::string text = fmt::format(
      "points: they cover {:.0f} % of what the training cameras see ({})",
      100 * coverage.training_covered, coverage.masked ? "inside their masks" : "of their images");
  std::string test;
  for (const CameraCoverage& c : coverage.cameras)
    if (c.unseen)
      test += fmt::format("{}{} {:.0f} %", test.empty() ? "" : ", ", scene.cameras[c.camera].name,
                          100 * *c.unseen);
  if (!test.empty()) text += "; seen by no training camera, of each test camera's points: " + test;
  return text;
}

std::vector<std::string> coverage_warnings(const Scene& scene, const Coverage& coverage) {
  std::vector<std::string> lines;
  if (coverage.training_covered < kLowPointCoverage)
    lines.push_back(fmt::format(
        "the points cover {:.0f} % of what the training cameras see ({}); where they are missing "
        "the model starts from nothing and renders fog there: masks (prepare --masks) give the "
        "hull, more cameras or cameras closer together give triangulated points",
        100 * coverage.training_covered,
        coverage.masked ? "inside their masks" : "of their images"));
  for (const CameraCoverage& c : coverage.cameras)
    if (c.unseen && *c.unseen > kHighUnseenShare)
      lines.push_back(fmt::format(
          "{:.0f} % of what test camera {} sees (at its points) no training camera sees: its novel "
          "view cannot be right there (a training camera nearer it would help)",
          100 * *c.unseen, scene.cameras[c.camera].name));
  return lines;
}

}  // namespace retimegs::io
