#pragma once
// Image files: 8/16-bit PNG and JPG in (libpng / libjpeg, silent: their warnings are dropped,
// their errors become the Error), PNG (libpng) and EXR out, atomically (media/other_codecs.hpp).
#include <filesystem>
#include <optional>

#include "retimegs/core/image.hpp"

namespace retimegs::media {

struct ImageSize {
  int width = 0, height = 0;
};

// RGB image with values in [0, 1] (8-bit / 255, 16-bit / 65535). Grey files are expanded to RGB,
// alpha is dropped. Throws Error naming the file when it is missing or cannot be decoded.
Image read_image(const std::filesystem::path& path);

// Single-channel mask: 1 where the stored value is > 127 (8-bit scale), else 0.
Image read_mask(const std::filesystem::path& path);

// The alpha channel of an image that has one (RGBA, grey + alpha) as a mask: 1 where alpha > 127
// (8-bit scale), else 0; nullopt for an image without alpha. Throws Error as read_image does.
std::optional<Image> read_alpha_mask(const std::filesystem::path& path);

// Width and height from the PNG / JPEG header without decoding the pixels (falls back to a full
// decode for other formats). Throws Error naming the file when it is missing or malformed.
ImageSize read_image_size(const std::filesystem::path& path);

// Silences OpenCV's own log lines on stderr (a failure is reported once, as the command's Error):
// called once at program start.
void quiet_opencv_log();

// Writes a 1-, 3- or 4-channel image in [0, 1] as an 8- or 16-bit PNG (values clamped, rounded);
// atomic, an existing `path` replaced only with `replace` (core/atomic_file.hpp).
void write_png(const std::filesystem::path& path, const Image& image, int bits = 8,
               bool replace = true);

// Whether this build's OpenCV writes OpenEXR (Debian's links OpenEXR; a build without it cannot).
bool can_write_exr();
// Throws Error naming `path` unless can_write_exr().
void check_exr_writer(const std::filesystem::path& path);

// Writes a 1-, 3- or 4-channel image as OpenEXR, half (16-bit) or 32-bit float per channel, the
// values as they are (not clamped). RGBA is written premultiplied, as EXR defines alpha (RGB
// times A; `image` holds straight colour). Throws Error naming the file when this build cannot
// write EXR (can_write_exr) or the write fails. Atomic, an existing `path` replaced only with
// `replace`.
void write_exr(const std::filesystem::path& path, const Image& image, bool float32 = false,
               bool replace = true);

}  // namespace retimegs::media
