#pragma once
// What a rig's initial points cover, and what its test cameras see that no training camera does:
// the two reasons a model of a sparse rig renders fog, measured before training so that `prepare`
// and `train` can say so in one line each instead of leaving the user to find it in the scores.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "retimegs/core/image.hpp"
#include "retimegs/io/ply.hpp"
#include "retimegs/io/scene.hpp"

namespace retimegs::io {

// A point covers the pixels within this fraction of the image's larger side of its projection
// (at least one pixel): about the footprint of an initial Gaussian on a cloud dense enough to
// train from. A pixel farther than that from every point is one the model has to grow into from
// nothing, which on a sparse rig it mostly does not.
constexpr double kCoverageRadiusFraction = 0.01;
// Relative depth slack of the visibility test (a point hidden behind another by more than this,
// along a camera's ray, is occluded there).
constexpr double kCoverageOcclusionTolerance = 0.03;
// prepare and train warn below this share of the training cameras' pixels covered by points ...
constexpr double kLowPointCoverage = 0.5;
// ... and for a test camera of which more than this share is seen by no training camera.
constexpr double kHighUnseenShare = 0.2;

// The frames of `count` (indices) that prepare and train measure: at most kCoverageFrames, evenly
// spread from the first to the last. What a rig covers changes little from frame to frame, and a
// capture stage's clip (dozens of cameras at 1K, hundreds of frames) would spend minutes on all.
constexpr std::size_t kCoverageFrames = 3;
std::vector<std::size_t> coverage_frames(std::size_t count);

struct CameraCoverage {
  int camera = 0;       // scene index
  double covered = 0;   // share of its pixels (in its masks) within reach of a point
  bool masked = false;  // its pixels were those of its masks at every frame
  // Test cameras: the share of its covered pixels whose nearest point no training camera sees
  // (outside every training image, or hidden there behind other points).
  std::optional<double> unseen;
};

struct Coverage {
  std::vector<CameraCoverage> cameras;  // every scene camera, in scene order
  double training_covered = 0;          // over the training cameras' pixels
  bool masked = false;                  // every training camera counted its masks' pixels
};

// Coverage summed over frames, one at a time (a frame's masks and points need not outlive add()).
class CoverageCounter {
 public:
  // Throws Error naming the scene when it has no training camera.
  explicit CoverageCounter(const Scene& scene);
  // One frame: its point cloud and, per scene camera, its mask there (foreground > 0.5) or
  // nullptr; a camera without a mask counts every pixel. `masks` is empty or one per camera.
  // Throws Error naming the camera whose mask's size is not its own.
  void add(const PointCloud& points, const std::vector<const Image*>& masks);
  // Over the frames added, each weighted by its pixels; zeros before any.
  Coverage result() const;

 private:
  struct Counts {
    std::size_t pixels = 0, covered = 0, unseen = 0;
    bool masked = true;
  };
  const Scene& scene_;
  std::vector<int> training_;
  std::vector<Counts> counts_;  // per scene camera
};

// One line for the log: the training cameras' coverage and each test camera's unseen share.
std::string describe_coverage(const Scene& scene, const Coverage& coverage);

// The warnings of `coverage` (kLowPointCoverage, kHighUnseenShare), one line each, for the log:
// empty when there is nothing to say.
std::vector<std::string> coverage_warnings(const Scene& scene, const Coverage& coverage);

}  // namespace retimegs::io
