#include "retimegs/media/resize.hpp"

#include <opencv2/imgproc.hpp>

namespace retimegs::media {

Image resize_area(const Image& image, int width, int height) {
  if (image.width == width && image.height == height) return image;
  cv::Mat src(image.height, image.width, CV_32FC(image.channels),
              const_cast<float*>(image.data.data()));
  Image out(width, height, image.channels);
  cv::Mat dst(height, width, CV_32FC(image.channels), out.data.data());
  cv::resize(src, dst, dst.size(), 0, 0, cv::INTER_AREA);
  return out;
}

Flow resize_flow(const Flow& flow, int width, int height) {
  if (flow.width == width && flow.height == height) return flow;
  // Known pixels' vectors and a coverage channel, averaged together: the mean over the known
  // ones is the averaged vector over the averaged coverage.
  Image weighted(flow.width, flow.height, 3);
  for (std::size_t i = 0; i < flow.pixels(); ++i) {
    const float known = flow.valid[i] ? 1.0f : 0.0f;
    weighted.data[3 * i] = known * flow.uv[2 * i];
    weighted.data[3 * i + 1] = known * flow.uv[2 * i + 1];
    weighted.data[3 * i + 2] = known;
  }
  const Image mean = resize_area(weighted, width, height);
  const float sx = float(width) / float(flow.width), sy = float(height) / float(flow.height);
  Flow out(width, height);
  for (std::size_t i = 0; i < out.pixels(); ++i) {
    const float coverage = mean.data[3 * i + 2];
    out.valid[i] = coverage >= 0.5f;
    out.uv[2 * i] = out.valid[i] ? sx * mean.data[3 * i] / coverage : 0.0f;
    out.uv[2 * i + 1] = out.valid[i] ? sy * mean.data[3 * i + 1] / coverage : 0.0f;
  }
  return out;
}

}  // namespace retimegs::media
