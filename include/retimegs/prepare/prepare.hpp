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

#include "retimegs/io/coverage.hpp"
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

// What a rig offers the default points.
struct PointsRig {
  std::size_t training_cameras = 0;
  bool every_view_has_mask = false;  // every training camera at every training frame
  bool masks_estimated = false;      // written by --masks (io::Scene::estimated_masks_marker)
  bool colmap_found = false;
  std::size_t stereo_pairs = 0;  // usable pairs (points_stereo.hpp: stereo_pairs)
};

// The points of the whole scene when --points is not given, and why, in one line.
struct PointsPlan {
  // Built at every frame and concatenated. Where one fails at a frame (COLMAP finds no point, the
  // hull is empty) the others' points stand for that frame, and the report says so.
  std::vector<PointsSource> sources;
  // Tried in order at a frame where every source failed; the first that builds stands.
  std::vector<PointsSource> fallbacks;
  // What is used and why, e.g. "hull (masks at every training view) + colmap with two-view
  // tracks (4 training cameras)".
  std::string summary;
  // Set where a source stands in for a missing one (COLMAP not installed): a warning.
  std::string note;
};

// The rule: every source of geometry the rig supports, concatenated per frame:
//  - the visual hull of the foreground when every training view has a mask of the capture's own
//    (masks written by --masks miss what moves little over the clip: their hull is only a fallback
//    where nothing else builds);
//  - COLMAP for the background (walls, floor, dome: a whole-image loss needs points there, or it
//    trains them to fog), with two-view tracks where the rig has few cameras
//    (keeps_two_view_tracks);
//  - dense pair stereo where the rig has no masks of its own, few cameras (keeps_two_view_tracks)
//    and a usable pair (points_stereo.hpp): COLMAP alone gives such a rig a few dozen points;
//  - random points stand in for COLMAP where it is not installed, and `note` says so.
// A frame where they give fewer than 100 points in all (prepare.cpp: kMinFramePoints) stops
// prepare with what to bring (masks, overlap, --points ply).
PointsPlan default_points(const PointsRig& rig);

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
  std::string points_plan;    // the default points: PointsPlan::summary (empty with --points)
  std::string points_note;    // PointsPlan::note
  // Frames of the default points where a source failed: what stood in, and why.
  struct PointsFallback {
    int frame = 0;
    std::string used;    // the sources whose points were written, "hull" or "colmap", ...
    std::string reason;  // the failures' messages
  };
  std::vector<PointsFallback> points_fallbacks;
  std::vector<std::pair<int, std::size_t>> points_written;  // (frame, points)
  std::size_t points_kept = 0;                              // files
  double masks_seconds = 0, flow_seconds = 0, points_seconds = 0;
  // What the points of the training frames cover (io/coverage.hpp), in the scene's masks where it
  // has them; none unless every training frame has points.
  std::optional<io::Coverage> coverage;
};

// Checks every input first (flow_dir files, PLY files, masks for the hull) so that bad input
// throws Error naming the file before anything is written; then writes what is missing.
PrepareReport prepare_scene(const io::Scene& scene, const PrepareOptions& options);

}  // namespace retimegs::prepare
