#pragma once
// What of image files needs OpenCV's imgcodecs: the formats other than PNG and JPEG, which
// image_io.cpp reads and writes with libpng and libjpeg themselves. other_codecs.cpp uses it;
// without_imgcodecs/ stands in for it in the lean GPU build (RETIMEGS_GPU_ONLY), whose OpenCV
// has no imgcodecs (its dependencies, GDAL first, are more than a bare GPU machine may be brought).
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace retimegs::media::detail {

// The file's pixels as imread(IMREAD_UNCHANGED) gives them (CMYK JPEG, BMP, TIFF, ...). Throws
// Error naming `name` when no decoder of this build takes them.
cv::Mat decode_other(const std::vector<unsigned char>& bytes, const std::string& name);

// OpenEXR of `bgr` (1, 3 or 4 float channels, BGR order), half or 32-bit float. Throws Error naming
// `name` when the encoder fails or this build has none (can_write_exr()).
std::vector<unsigned char> encode_exr(const cv::Mat& bgr, bool float32, const std::string& name);

}  // namespace retimegs::media::detail
