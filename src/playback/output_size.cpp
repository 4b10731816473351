#include "retimegs/playback/output_size.hpp"

#include <algorithm>
#include <cmath>
#include <regex>

#include "retimegs/core/error.hpp"
#include "retimegs/core/limits.hpp"

namespace retimegs::playback {

OutputSize parse_output_size(const std::string& text) {
  static const std::regex pattern(R"((\d{1,6})x(\d{1,6}))");
  std::smatch m;
  OutputSize size;
  if (std::regex_match(text, m, pattern)) {
    size.width = std::stoi(m[1].str());
    size.height = std::stoi(m[2].str());
  }
  if (size.width < kMinOutputSide || size.height < kMinOutputSide || size.width > kMaxImageSide ||
      size.height > kMaxImageSide)
    fail("--size: expected WxH with W and H whole numbers from {} to {} (1920x1080), got '{}'",
         kMinOutputSide, kMaxImageSide, text);
  return size;
}

Camera at_output_size(const Camera& camera, const OutputSize& size) {
  const int w = camera.width, h = camera.height;
  if (size.width > 0) {
    const bool same_aspect = size.height == std::lround(double(size.width) * h / w) ||
                             size.width == std::lround(double(size.height) * w / h);
    if (!same_aspect)
      fail(
          "--size: {}x{} has another aspect ratio than camera '{}' ({}x{}); at width {} it is "
          "{}x{}",
          size.width, size.height, camera.name, w, h, size.width, size.width,
          std::max(1L, std::lround(double(size.width) * h / w)));
    return resized(camera, size.width, size.height);
  }
  if (size.scale) {
    const double s = *size.scale;
    if (!std::isfinite(s) || !(s > 0)) fail("--scale: must be a finite number > 0, got {}", s);
    const double sw = std::round(s * w), sh = std::round(s * h);
    check_output_size(sw, sh,
                      fmt::format("--scale: {} makes camera '{}' ({}x{})", s, camera.name, w, h));
    return resized(camera, int(sw), int(sh));
  }
  return camera;
}

}  // namespace retimegs::playback
