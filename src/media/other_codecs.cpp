#include "other_codecs.hpp"

#include <opencv2/imgcodecs.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/media/image_io.hpp"

namespace retimegs::media {

bool can_write_exr() {
  return cv::haveImageWriter(".exr");
}

namespace detail {

cv::Mat decode_other(const std::vector<unsigned char>& bytes, const std::string& name) {
  cv::Mat m;
  try {
    m = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    fail("{}: cannot decode image: {}", name, e.err);
  }
  if (m.empty()) fail("{}: cannot decode image", name);
  return m;
}

std::vector<unsigned char> encode_exr(const cv::Mat& bgr, bool float32, const std::string& name) {
  const std::vector<int> params = {
      cv::IMWRITE_EXR_TYPE, float32 ? cv::IMWRITE_EXR_TYPE_FLOAT : cv::IMWRITE_EXR_TYPE_HALF};
  std::vector<unsigned char> bytes;
  bool ok = false;
  try {
    ok = cv::imencode(".exr", bgr, bytes, params);
  } catch (const cv::Exception& e) {
    fail("{}: cannot encode EXR: {}", name, e.err);
  }
  if (!ok) fail("{}: cannot encode EXR", name);
  return bytes;
}

}  // namespace detail
}  // namespace retimegs::media
