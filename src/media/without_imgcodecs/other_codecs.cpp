// The lean GPU build's image files (RETIMEGS_GPU_ONLY: OpenCV without imgcodecs): PNG and JPEG
// only, which image_io.cpp reads and writes with libpng and libjpeg.
#include "../other_codecs.hpp"

#include "retimegs/core/error.hpp"
#include "retimegs/media/image_io.hpp"

namespace retimegs::media {

bool can_write_exr() {
  return false;
}

namespace detail {

cv::Mat decode_other(const std::vector<unsigned char>&, const std::string& name) {
  fail(
      "{}: neither PNG nor an RGB or grey JPEG, the only images this build reads (the lean GPU "
      "build has no OpenCV imgcodecs)",
      name);
}

std::vector<unsigned char> encode_exr(const cv::Mat&, bool, const std::string& name) {
  fail(
      "{}: this build cannot write OpenEXR (the lean GPU build has no OpenCV imgcodecs); write "
      "PNGs instead",
      name);
}

}  // namespace detail
}  // namespace retimegs::media
