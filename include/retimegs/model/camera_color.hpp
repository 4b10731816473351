#pragma once
// Per-camera colour correction (Dynamic 3D Gaussians' cam_m, cam_c; docs/method.md): a real rig's
// cameras differ in gain and white balance, so training learns for each training camera an affine
// map per channel, rgb' = exp(m) ⊙ rgb + c, applied to the render before the image loss. The
// model's own colours are then those of the average camera; a render from a training camera
// applies its map to look like that camera's images.
#include <array>

#include "retimegs/core/hd.hpp"
#include "retimegs/core/image.hpp"

namespace retimegs::model {

struct CameraColor {
  std::array<float, 3> m{};  // log gain per channel (0: gain 1)
  std::array<float, 3> c{};  // offset per channel
};

// One value through the map: gain · value + offset, gain = exp(m).
RETIMEGS_HD inline float camera_color_value(float gain, float value, float offset) {
  return gain * value + offset;
}

// out = exp(m) ⊙ rgb + c per channel; rgb [H, W, 3] (a render's RGB, not its flow channels).
// `out` takes rgb's shape and may be rgb itself.
void apply_camera_color(const Image& rgb, const CameraColor& color, Image& out);

// Backward of apply_camera_color at `rgb`. v_render [H, W, C >= 3] holds d loss / d out in its
// first 3 channels on entry and d loss / d rgb there on return (× exp(m)); its other channels (a
// render's flow) are left as they are. d loss / d m and d loss / d c are added to v_color.
void apply_camera_color_backward(const Image& rgb, const CameraColor& color, Image& v_render,
                                 CameraColor& v_color);

}  // namespace retimegs::model
