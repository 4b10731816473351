#pragma once
// The times of a render's or an export's frames, in scene frame units (frame k is time k): a
// range A:B:STEP, slow motion over a clip, a speed ramp's keyframes interpolated.
#include <string>
#include <vector>

#include "retimegs/core/limits.hpp"
#include "retimegs/media/frame_writer.hpp"

namespace retimegs::playback {

// Throws Error naming `flag` when `frames` is more than core/limits.hpp's kMaxOutputFrames.
void check_frame_count(double frames, const std::string& flag);

// --times A:B:STEP.
struct TimeRange {
  double first = 0, last = 0, step = 0;
};

// first, first + step, ... up to last (inclusive, with a 1e-9 tolerance). Throws Error naming
// `flag` unless first <= last and step > 0, and when it would be more than kMaxOutputFrames.
std::vector<double> range_times(const TimeRange& range, const std::string& flag);

// --slowmo F: F frames per scene-frame interval from time `first` to `last`, t = first + k / F
// for k = 0 .. round((last - first) F). Throws Error naming --slowmo unless F >= 1, and when it
// would be more than kMaxOutputFrames.
std::vector<double> slowmo_times(double first, double last, int factor);

// --retime: one time per output frame from the first keyframe's to the last's, linearly
// interpolated between keyframes; `keys` as media::read_retime_csv gives them (in increasing
// output-frame order; none: no frames).
std::vector<double> ramp_times(const std::vector<media::RetimeKey>& keys);

}  // namespace retimegs::playback
