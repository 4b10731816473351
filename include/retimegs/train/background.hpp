#pragma once
// Training over a random background (gsplat's random_bkgd; docs/method.md, "Background"). A step
// draws one colour; every render pass of the step (the all-primitives render and both group
// renders of triple rendering) composites its RGB over it and its flow channels over 0, as
// before (a flow has no background: a flow render is what the primitives carry). Where the view
// has a mask, the target's background pixels take the colour as the step's camera records it
// (through its colour map), so that the model cannot paint the capture's background into its
// primitives and leaves it transparent. Without masks the target stays the image: transparency
// shows the step's colour and costs loss, so the model becomes opaque where the images are and
// its alpha is coverage, a matte (`render --alpha`).
#include <array>
#include <cstdint>
#include <vector>

#include "retimegs/core/image.hpp"
#include "retimegs/model/camera_color.hpp"
#include "retimegs/train/config.hpp"
#include "retimegs/train/dataset.hpp"

namespace retimegs::train {

using Rgb = std::array<float, 3>;

// The background of step `iteration` of a run seeded `seed`: each channel uniform in [0, 1), a
// counter-based hash (splitmix64) of (seed, iteration) alone. It needs no state of its own: the
// CPU and the CUDA step draw the same colour, and a resumed run those of the uninterrupted one.
Rgb step_background(std::uint64_t seed, int iteration);

// Whether training `set` with `config` draws random backgrounds: config.random_background when
// set; unset, on when no training view has a mask (a capture's masks would otherwise make the
// model leave their background out, which a whole-image score counts).
bool random_background(const TrainConfig& config, const TrainingSet& set);

// What a camera with colour map `color` records of a backdrop of colour `background`: the map's
// image of it (model::apply_camera_color), which a transparent render shows through the map.
Rgb seen_background(const Rgb& background, const model::CameraColor& color);

// target [H, W, 3]: every pixel that `mask` [H, W, 1] does not mark foreground (core/image.hpp
// is_foreground) set to `background`. Throws Error unless the mask has the target's size.
void replace_background(Image& target, const Image& mask, const Rgb& background);

// The mask [H, W, 1] as 1 (foreground, is_foreground) or 0 per pixel [H, W]: the form in which the
// CUDA step's target (cuda::DeviceSsimTarget::assign) reads it.
std::vector<std::uint8_t> foreground_flags(const Image& mask);

}  // namespace retimegs::train
