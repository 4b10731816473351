#include "retimegs/core/limits.hpp"

#include <cmath>

#include "retimegs/core/error.hpp"

namespace retimegs {

void check_image_side(double side, const std::string& field) {
  if (!(side >= 1 && side <= kMaxImageSide))
    fail("{} = {} must lie in [1, {}] pixels", field, side, kMaxImageSide);
}

void check_output_size(double width, double height, const std::string& field) {
  const auto inside = [](double side) { return side >= kMinOutputSide && side <= kMaxImageSide; };
  if (!inside(width) || !inside(height))
    fail("{} {}x{}: each side must lie in [{}, {}] pixels", field, width, height, kMinOutputSide,
         kMaxImageSide);
}

void check_frame_count(long frames, const std::string& field) {
  if (frames < 1 || frames > kMaxFrames)
    fail("{} = {} frames must lie in [1, {}]", field, frames, kMaxFrames);
}

void check_fps(double fps, const std::string& field) {
  if (!(fps >= kMinFps && fps <= kMaxFps))
    fail("{} = {} must lie in [{:.4g}, {}] frames per second", field, fps, kMinFps, kMaxFps);
}

void check_focal(double focal, int side, const std::string& field) {
  if (!(focal >= kMinFocalPerSide * side && focal <= kMaxFocalPerSide * side))
    fail("{} = {} must lie in [{:g}, {:g}] pixels ({} to {} times the image side of {})", field,
         focal, kMinFocalPerSide * side, kMaxFocalPerSide * side, kMinFocalPerSide,
         kMaxFocalPerSide, side);
}

void check_coordinate(double value, const std::string& field) {
  if (!(std::abs(value) <= kMaxCoordinate))
    fail("{} = {} lies beyond {:g} scene units of the origin", field, value, kMaxCoordinate);
}

void check_seam_fade(double intervals, const std::string& field) {
  if (!(intervals >= 0 && intervals <= kMaxSeamFade))
    fail("{} = {} must lie in [0, {}] training intervals", field, intervals, kMaxSeamFade);
}

}  // namespace retimegs
