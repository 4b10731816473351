// The importers of videos in the lean GPU build (RETIMEGS_GPU_ONLY), whose OpenCV has no videoio
// (FFmpeg and GStreamer are more than a bare GPU machine may be brought): they name what is
// missing. Images import as in every build (panoptic, colmap, nerfstudio).
#include "retimegs/core/error.hpp"
#include "retimegs/ingest/import.hpp"

namespace retimegs::ingest {

namespace {
[[noreturn]] void no_videos(const std::filesystem::path& source, const char* format) {
  fail(
      "{}: import {} decodes videos, which this build cannot (the lean GPU build has no OpenCV "
      "videoio): import on a build machine and bring the scene",
      source.string(), format);
}
}  // namespace

void import_n3dv(const std::filesystem::path& source, const std::filesystem::path&,
                 const ImportOptions&) {
  no_videos(source, "n3dv");
}

VideosReport import_videos(const std::filesystem::path& source, const std::filesystem::path&,
                           const ImportOptions&, const VideosOptions&) {
  no_videos(source, "videos");
}

}  // namespace retimegs::ingest
