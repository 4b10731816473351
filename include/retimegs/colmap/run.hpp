#pragma once
// The COLMAP command line, run headless: finding the executable, one runner for every command
// (its output in a log, a failure explained in a user's words with the log's path), the SIFT
// extraction and matching options both callers share, and the temporary work folder. Used by
// `prepare --points colmap` (triangulation with known poses) and `import videos` without a
// calibration (feature extraction, matching and the mapper). The model files COLMAP writes are
// io/colmap.hpp's.
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace retimegs::colmap {

struct ColmapOptions {
  std::string executable = "colmap";  // looked up on PATH unless it contains a '/'
  int max_image_size = 3200;          // --SiftExtraction.max_image_size
  int max_num_features = 8192;        // --SiftExtraction.max_num_features
  // --SiftExtraction.peak_threshold: below COLMAP's 0.0067, the faint texture of walls, floor
  // and dome (the background the hull leaves empty) gives features too, not only the people.
  double peak_threshold = 0.002;
  // --SiftMatching.guided_matching: once a pair's geometry is verified, match again along it,
  // recovering matches of repeated or faint texture that the ratio test alone rejects.
  bool guided_matching = true;
  // --ImageReader.camera_model of the cameras a calibration is recovered for, each its own: set by
  // `import videos` without --calib (ingest/import.hpp: VideosOptions::camera_model).
  std::string camera_model;
  int threads = -1;                   // COLMAP's num_threads (-1 = all cores)
  double max_reprojection_error = 4;  // --Mapper.filter_max_reproj_error, pixels
  // `prepare --points colmap`: points seen by fewer cameras are dropped: a two-view point only
  // has to agree with one epipolar line, so repeated texture makes many wrong ones; a third view
  // rejects them. A rig too sparse for three-view matches keeps checked two-view points
  // (prepare/colmap_triangulate.hpp: keeps_two_view_tracks).
  int min_track_length = 3;
  bool verbose = false;  // pass COLMAP's output through to stderr
};

// The COLMAP executable of options (PATH lookup); throws Error when it is not installed.
std::filesystem::path find_colmap(const ColmapOptions& options);
// Whether find_colmap() finds it.
bool colmap_available(const ColmapOptions& options);

// Runs `exe step args...` headless (QT_QPA_PLATFORM=offscreen), stdout and stderr into
// log_dir/<step>.log (both to stderr with `verbose`). Throws Error when it fails: "colmap <step>
// failed (<exit status or signal>)", what that means in a user's words where its log says why,
// the log's error line and the log's path (as shown_path() shows it). A Ctrl-C or SIGTERM ends
// the command and throws Interrupted.
void run_colmap(const std::filesystem::path& exe, const std::string& step,
                const std::vector<std::string>& args, const std::filesystem::path& log_dir,
                bool verbose);

// The arguments of `colmap feature_extractor` (CPU SIFT) after the database, image folder and
// camera options, and those of `colmap exhaustive_matcher` (CPU) after the database.
std::vector<std::string> sift_extraction_args(const ColmapOptions& options);
std::vector<std::string> exhaustive_matching_args(const ColmapOptions& options);

// A number as a COLMAP argument, at full double precision.
std::string number(double v);

// A fresh folder for COLMAP's images, database and models: <temp>/retimegs-colmap-<pid>-<name>,
// removed with everything in it when the object goes, on success, error or interrupt alike.
class WorkFolder {
 public:
  explicit WorkFolder(std::string_view name);
  WorkFolder(const WorkFolder&) = delete;
  WorkFolder& operator=(const WorkFolder&) = delete;
  ~WorkFolder();
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace retimegs::colmap
