#pragma once
// The image size `retimegs render` writes: the camera's own, or --size WxH, or --scale S. The
// camera then renders at that size (its intrinsics scaled, core resized()): the image is rendered
// there, never resampled.
#include <optional>
#include <string>

#include "retimegs/core/camera.hpp"

namespace retimegs::playback {

struct OutputSize {
  int width = 0, height = 0;    // --size; 0: not given
  std::optional<double> scale;  // --scale
};

// "WxH" (1920x1080) -> {W, H}; throws Error naming --size unless both are integers in
// [kMinOutputSide, kMaxImageSide] (core/limits.hpp).
OutputSize parse_output_size(const std::string& text);

// `camera` at the output size (neither given: unchanged). --size W x H must keep the camera's
// aspect ratio up to rounding to whole pixels: H = round(W * camera.height / camera.width) or
// W = round(H * camera.width / camera.height). --scale S gives round(S * width) x
// round(S * height); S finite and > 0. Throws Error naming the option and the camera otherwise,
// or when a side would lie outside [kMinOutputSide, kMaxImageSide].
Camera at_output_size(const Camera& camera, const OutputSize& size);

}  // namespace retimegs::playback
