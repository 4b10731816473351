#pragma once
// Cameras synchronised from their footage (`import videos --sync auto`): each camera's clock
// offset against a reference camera, from when things move in its view. Pure functions: the
// importer decodes the frames and feeds them in (import_videos.cpp).
#include <string>
#include <vector>

#include "retimegs/core/image.hpp"

namespace retimegs::ingest {

// Long side of the grey thumbnails whose differences make the motion energy: enough to see what
// moves, small enough that sensor noise and compression artefacts average out.
constexpr int kSyncThumbnailSide = 64;

// A camera's motion energy, fed its source frames one at a time in decoding order (so that no
// camera's frames are held at once): value j is the mean absolute difference of the grey
// thumbnails (kSyncThumbnailSide) of frames j and j + 1, in [0, 1].
class MotionEnergy {
 public:
  // The camera's next source frame, of any number of channels (their mean is the grey); every
  // frame has the first one's size.
  void add(const Image& frame);
  const std::vector<double>& signal() const { return signal_; }  // [frames - 1]

 private:
  Image previous_;
  std::vector<double> signal_;
};

// The signal minus its mean, divided by its standard deviation; all zeros where it is (nearly)
// constant, which no shift can be measured from.
std::vector<double> z_normalised(const std::vector<double>& signal);

// The signal at position x in [0, size - 1], linearly interpolated between its samples.
double sample_linear(const std::vector<double>& signal, double x);

// The bound on the lags searched, by default: a quarter of the frames every camera has (a clip
// whose cameras are off by more than that has too little footage in common to tell).
int default_max_lag(int common_frames);

// Below this peak correlation, or with a runner-up this close to the peak, a lag is not to be
// trusted: the footage moves too little, or alike at two lags (a periodic motion).
constexpr double kMinSyncPeak = 0.5;
constexpr double kMinSyncMargin = 0.1;

// --sync auto writes offsets in steps of this many frames: no finer than the motion energy resolves
// a shift (its worst error over seeded synthetic rigs of 25 frames is about 0.09 frame), so that a
// camera found within half a step of the reference, or of a whole frame from it, keeps a
// whole-frame offset exactly. Its views then stay
// on the training grid, with the triple rendering and flow loss of genlocked cameras, which a
// clock a hundredth of a frame off would lose for nothing (docs/method.md, "Cameras on their own
// clocks").
constexpr double kSyncResolution = 0.1;
// x rounded to the nearest multiple of kSyncResolution (halves away from zero).
double round_to_sync_resolution(double x);

struct LagEstimate {
  // other[j] matches reference[j + lag]: the other camera's frame j shows what the reference
  // camera's shows at frame j + lag (so its --offsets value is -lag).
  double lag = 0;
  double peak = 0;       // normalised cross-correlation at `lag`, in [-1, 1]
  double runner_up = 0;  // the highest other local maximum over whole lags 2 or more away; -1: none
  std::string weak;      // empty, or why the lag is not to be trusted (for a warning)
};

// The lag in [-max_lag, max_lag] that maximises the normalised cross-correlation (Pearson's, over
// the samples both signals have) of `reference` and `other`: first over whole lags, then at
// sub-frame resolution within one frame of the best, `reference` resampled by linear
// interpolation at the fractional lag over a fixed set of samples (unbiased for smooth signals,
// where fitting a parabola to the whole-lag peak is not). Lags that leave fewer than half the
// shorter signal in common are not searched. Throws Error when either signal has fewer than
// kMinSyncSamples samples or max_lag < 1.
constexpr int kMinSyncSamples = 4;
LagEstimate estimate_lag(const std::vector<double>& reference, const std::vector<double>& other,
                         int max_lag);

}  // namespace retimegs::ingest
