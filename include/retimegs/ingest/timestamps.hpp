#pragma once
// Per-frame timestamps as webcam and software-sync tools log them (`import videos --timestamps`,
// docs/formats.md "Timestamps"): CSV lines `camera,frame,seconds`, an optional header line,
// `frame` the camera's 0-based source frame in decoding order, `seconds` on any clock common to
// every camera.
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace retimegs::ingest {

struct FrameTimestamp {
  double seconds = 0;
  int line = 0;  // in the file, from 1, for messages
};

struct Timestamps {
  std::filesystem::path file;
  // camera -> source frame -> its time; every camera named in the file is one of the footage's
  std::map<std::string, std::map<int, FrameTimestamp>> cameras;
};

// Reads the file for cameras `names`. Throws Error naming the file, the line and the value for a
// line that is not three fields, a camera not among `names`, a frame that is not a non-negative
// integer, seconds that are not a finite number, a camera's frame given twice, or seconds that do
// not increase with the camera's frames.
Timestamps read_timestamps(const std::filesystem::path& file,
                           const std::vector<std::string>& names);

// The frame_times (io::CameraClock) of the scene's cameras `names` for `count` scene frames,
// camera c's scene frame k being its source frame first[c] + k: (its seconds - the seconds of
// names[0]'s scene frame 0) * fps, in scene frames. Throws Error naming the file, the camera and
// the frame where one has no timestamp.
std::vector<std::vector<double>> frame_times_from_timestamps(const Timestamps& timestamps,
                                                             const std::vector<std::string>& names,
                                                             const std::vector<int>& first,
                                                             int count, double fps);

}  // namespace retimegs::ingest
