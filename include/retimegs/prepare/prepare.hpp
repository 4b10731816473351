#pragma once
// `retimegs prepare`: fills in what training needs that a scene lacks (docs/cli.md):
//  - flow/<camera>/<from:05d>_<to:05d>.flo in both directions for every training camera and every
//    pair of io::training_views() (the flows training reads). Test cameras get none;
//  - points/<frame:05d>.ply at every training frame;
//  - with `masks` set, first masks/<camera>/<frame:05d>.png (approximate, prepare/masks.hpp) for
//    every camera at every frame, so that the points and the evaluation see a scene with masks.
// Existing files are kept unless `force`, so a re-run resumes; every file is written atomically.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "retimegs/io/scene.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/prepare/colmap_triangulate.hpp"
#include "retimegs/prepare/flow_estimate.hpp"
#include "retimegs/prepare/masks.hpp"
#include "retimegs/prepare/points.hpp"
#include "retimegs/prepare/points_stereo.hpp"

namespace retimegs::prepare {

enum class PointsSource {
  kHull,    // visual_hull()
  kRandom,  // random_points(): the last resort
  kPly,     // read_frame_points(points_dir / "<frame:05d>.ply")
  kColmap,  // prepare/colmap_triangulate.hpp's triangulate_with_colmap with `colmap` below
  kStereo,  // stereo_points(): dense depth from camera pairs (prepare/points_stereo.hpp)
};

struct PrepareOptions {
  io::FrameSelection frames = io::FrameSelection::kEven;
  FlowMethod flow_method = FlowMethod::kDis;
  ConsistencyOptions consistency;
  // Non-empty: import flow_dir/<camera>/<from:05d>_<to:05d>.flo (the scene's own naming, e.g.
  // written by a WAFT / RAFT / SEA-RAFT script) instead of estimating. Copied byte for byte after
  // validation (readable .flo, the camera's image size); no consistency check is applied.
  std::filesystem::path flow_dir;
  // Sources whose clouds are concatenated per frame (e.g. hull + colmap: the dense foreground of
  // the masks and COLMAP's static background). Empty: default_points().
  std::vector<PointsSource> points;
  std::filesystem::path points_dir;  // for kPly
  ColmapOptions colmap;              // kColmap; it works in a temporary folder (colmap::WorkFolder)
  HullOptions hull;
  StereoOptions stereo;
  // Set: background-model masks for the cameras missing one, learnt from the training frames.
  // They are approximate (they miss what moves little over the clip), so the default points then
  // and in every later run stay those of a scene without masks
  // (io::Scene::estimated_masks_marker());
  // --points hull,... uses them.
  std::optional<MaskOptions> masks;
  // kRandom's points in all, spread over the training frames (at least kMinRandomPointsPerFrame
  // each) as training's fallback seeds the same number at once.
  std::size_t random_points_total = io::kRandomPointsTotal;
  // Set (prepare --window): only the flows and points of the window's training frames, so that
  // each window of a long clip prepares its own part (io::training_views with the window). Not
  // with `masks`, which learn from the whole clip's frames and write every frame.
  std::optional<io::FrameWindow> window;
  std::uint64_t seed = 0;
  bool force = false;
  bool progress = true;
};

constexpr std::size_t kMinRandomPointsPerFrame = 1000;

// The points of the whole scene when --points is not given: the visual hull for the foreground
// when every training camera has a mask at every training frame, plus COLMAP for the background
// (walls, floor, dome: a whole-image loss needs points there, or it trains them to fog); COLMAP
// alone without masks. When COLMAP is not found, random points stand in for it (hull + random,
// or random alone) and `note` says so (else it is cleared).
std::vector<PointsSource> default_points(bool every_view_has_mask, bool colmap_found,
                                         std::string& note);

// One camera's flows estimated by a run, as the forward-backward check judged them: the share of
// their pixels marked unknown. Occlusions mark some in every camera; a camera far above the others
// has flows the estimator got wrong (motion blur, an exposure jump, a wrong frame offset), which
// training would learn from.
struct CameraFlowCheck {
  int camera = 0;  // index into the scene's cameras
  std::size_t flows = 0;
  double unknown_fraction = 0;
};

struct PrepareReport {
  std::size_t masks_written = 0, masks_kept = 0;  // files
  double mask_coverage = 0;                       // mean foreground share of the masks written
  std::size_t flows_written = 0, flows_kept = 0;  // files
  bool flows_imported = false;
  double unknown_fraction = 0;  // of the estimated flows' pixels: marked by the consistency check
  // The cameras whose flows this run estimated, the highest unknown share first.
  std::vector<CameraFlowCheck> flow_by_camera;
  std::string points_source;  // "hull", "random", "ply", "colmap", "hull,colmap", ... (empty:
                              // nothing to do)
  std::string points_note;    // why the default points are what they are, when not as planned
  std::vector<std::pair<int, std::size_t>> points_written;  // (frame, points)
  std::size_t points_kept = 0;                              // files
  double masks_seconds = 0, flow_seconds = 0, points_seconds = 0;
};

// Checks every input first (flow_dir files, PLY files, masks for the hull) so that bad input
// throws Error naming the file before anything is written; then writes what is missing.
PrepareReport prepare_scene(const io::Scene& scene, const PrepareOptions& options);

}  // namespace retimegs::prepare
