#include "retimegs/playback/times.hpp"

#include <cmath>
#include <iterator>

#include "retimegs/core/error.hpp"

namespace retimegs::playback {

void check_frame_count(double frames, const std::string& flag) {
  if (frames > kMaxOutputFrames)
    fail("{}: {:.0f} frames; at most {} frames are rendered in one command", flag, frames,
         kMaxOutputFrames);
}

std::vector<double> range_times(const TimeRange& range, const std::string& flag) {
  const double a = range.first, b = range.last, step = range.step;
  if (!(step > 0) || b < a) fail("{}: need A <= B and STEP > 0, got '{}:{}:{}'", flag, a, b, step);
  check_frame_count((b - a) / step + 1, flag);
  std::vector<double> times;
  for (long k = 0; a + k * step <= b + 1e-9; ++k) times.push_back(a + k * step);
  return times;
}

std::vector<double> slowmo_times(double first, double last, int factor) {
  if (factor < 1) fail("--slowmo: must be >= 1, got {}", factor);
  check_frame_count((last - first) * factor + 1, "--slowmo");
  std::vector<double> times;
  const long count = std::lround((last - first) * factor);
  for (long k = 0; k <= count; ++k) times.push_back(first + double(k) / factor);
  return times;
}

std::vector<double> ramp_times(const std::vector<media::RetimeKey>& keys) {
  std::vector<double> times;
  if (keys.empty()) return times;
  auto it = keys.begin();
  for (int frame = keys.front().output_frame; frame <= keys.back().output_frame; ++frame) {
    auto next = std::next(it);
    if (next != keys.end() && frame >= next->output_frame) it = next++;
    if (next == keys.end()) {
      times.push_back(it->t);
    } else {
      const double s =
          double(frame - it->output_frame) / double(next->output_frame - it->output_frame);
      times.push_back(it->t + s * (next->t - it->t));
    }
  }
  return times;
}

}  // namespace retimegs::playback
