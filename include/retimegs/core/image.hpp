#pragma once
// Float images, interleaved channels, row-major: data[(y * width + x) * channels + c].
// Colour values are linear in the file's 8/16-bit code values, scaled to [0, 1].
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "retimegs/core/hd.hpp"

namespace retimegs {

struct Image {
  int width = 0, height = 0, channels = 0;
  std::vector<float> data;  // [H, W, C]

  Image() = default;
  Image(int w, int h, int c, float fill = 0.0f)
      : width(w), height(h), channels(c), data(std::size_t(w) * h * c, fill) {}

  std::size_t pixels() const { return std::size_t(width) * height; }
  bool empty() const { return data.empty(); }
  float& at(int y, int x, int c = 0) { return data[(std::size_t(y) * width + x) * channels + c]; }
  float at(int y, int x, int c = 0) const {
    return data[(std::size_t(y) * width + x) * channels + c];
  }
  float* pixel(int y, int x) { return &data[(std::size_t(y) * width + x) * channels]; }
  const float* pixel(int y, int x) const { return &data[(std::size_t(y) * width + x) * channels]; }
};

// An image kept at 16 bits per value, value = code / 65535: half the memory of an Image, for the
// training views held through a whole run. Exact for what media::read_image gives: its 8-bit values
// k / 255 are the codes 257 k, its 16-bit values the codes themselves (tests/core checks all).
struct PackedImage {
  int width = 0, height = 0, channels = 0;
  std::vector<std::uint16_t> data;  // [H, W, C]
  std::size_t bytes() const { return data.size() * sizeof(std::uint16_t); }
};

// The value of a code, as unpack() gives it (and the CUDA backend's unpacking on the device).
RETIMEGS_HD inline float unpack_code(std::uint16_t code) {
  return float(double(code) * (1.0 / 65535.0));
}

// Rounds to the nearest code; throws Error naming `what` and the pixel of a value outside [0, 1]
// or not finite.
PackedImage pack(const Image& image, const std::string& what);
// The float image, written into `out` (resized; its allocation is reused).
void unpack(const PackedImage& packed, Image& out);

// Masks are [H, W, 1] with foreground where > 0.5 (media::read_mask gives 0 / 1; a soft mask is
// split at one half).
constexpr float kMaskThreshold = 0.5f;
inline bool is_foreground(const Image& mask, std::size_t pixel) {
  return mask.data[pixel] > kMaskThreshold;
}

// For functions that compare images; each throws Error naming `function`. check_image_pair: a and
// b agree in size and channels, are not empty and hold finite values only (the message names the
// first bad value's pixel and channel). check_mask: the mask is [H, W, 1] at the image's size.
void check_image_pair(const Image& a, const Image& b, const char* function);
void check_mask(const Image& mask, const Image& image, const char* function);

// Dense 2-D motion field (Middlebury convention): pixel (x, y) of the source frame moves to
// (x + u, y + v) in the target frame. Unknown pixels (occluded / out of view; stored as
// |u| or |v| > 1e9 in .flo files) have valid = 0 and uv = 0.
struct Flow {
  int width = 0, height = 0;
  std::vector<float> uv;             // [H, W, 2]
  std::vector<unsigned char> valid;  // [H, W] 1 = known

  Flow() = default;
  Flow(int w, int h)
      : width(w), height(h), uv(std::size_t(w) * h * 2, 0.0f), valid(std::size_t(w) * h, 1) {}
  std::size_t pixels() const { return std::size_t(width) * height; }
};

// Bilinear sample of channel c at continuous coordinates (u, v) with pixel centres at +0.5;
// coordinates are clamped to the image.
float sample_bilinear(const Image& image, double u, double v, int c);

}  // namespace retimegs
