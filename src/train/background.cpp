#include "retimegs/train/background.hpp"

#include "retimegs/core/splitmix64.hpp"

namespace retimegs::train {

namespace {
// Keeps the background's draws apart from any other hash of the seed.
constexpr std::uint64_t kBackgroundStream = 0x6261636b67726f75ULL;  // "backgrou"
}  // namespace

Rgb step_background(std::uint64_t seed, int iteration) {
  const std::uint64_t base =
      splitmix64(splitmix64(seed ^ kBackgroundStream) ^ std::uint64_t(std::uint32_t(iteration)));
  Rgb rgb;
  // 24 bits per channel: a float in [0, 1) exactly, the same on every device.
  for (int k = 0; k < 3; ++k)
    rgb[k] = float(splitmix64(base + std::uint64_t(k)) >> 40) * 0x1.0p-24f;
  return rgb;
}

bool random_background(const TrainConfig& config, const TrainingSet& set) {
  if (config.random_background) return *config.random_background;
  for (const auto& camera : set.masks)
    for (const auto& mask : camera)
      if (mask) return false;
  return true;
}

Rgb seen_background(const Rgb& background, const model::CameraColor& color) {
  Image pixel(1, 1, 3);
  for (int k = 0; k < 3; ++k) pixel.data[k] = background[k];
  model::apply_camera_color(pixel, color, pixel);
  return {pixel.data[0], pixel.data[1], pixel.data[2]};
}

void replace_background(Image& target, const Image& mask, const Rgb& background) {
  check_mask(mask, target, "replace_background");
  const std::size_t pixels = target.pixels();
  for (std::size_t p = 0; p < pixels; ++p)
    if (!is_foreground(mask, p))
      for (int k = 0; k < 3; ++k) target.data[3 * p + k] = background[k];
}

std::vector<std::uint8_t> foreground_flags(const Image& mask) {
  std::vector<std::uint8_t> flags(mask.pixels());
  for (std::size_t p = 0; p < flags.size(); ++p) flags[p] = is_foreground(mask, p) ? 1 : 0;
  return flags;
}

}  // namespace retimegs::train
