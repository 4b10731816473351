// Foreground masks from a background model of a static camera's clip (prepare/masks.hpp).
#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/background_segm.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/prepare/masks.hpp"

namespace retimegs::prepare {

namespace {

// MOG2 marks foreground 255 and shadows 127; shadows belong to the background here.
constexpr unsigned char kForeground = 255;

cv::Mat to_bgr8(const Image& image) {
  cv::Mat rgb(image.height, image.width, image.channels == 1 ? CV_8UC1 : CV_8UC3);
  for (int y = 0; y < image.height; ++y) {
    unsigned char* row = rgb.ptr<unsigned char>(y);
    const float* src = image.pixel(y, 0);
    for (int i = 0; i < image.width * image.channels; ++i)
      row[i] = cv::saturate_cast<unsigned char>(src[i] * 255.0f);
  }
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, image.channels == 1 ? cv::COLOR_GRAY2BGR : cv::COLOR_RGB2BGR);
  return bgr;
}

// Opening removes specks, closing joins the pieces of one body, then components below the
// minimum area go and holes (background not connected to the image border) are filled.
cv::Mat clean(const cv::Mat& raw, const MaskOptions& options) {
  cv::Mat mask = raw == kForeground;
  cv::morphologyEx(mask, mask, cv::MORPH_OPEN,
                   cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
  const int side =
      std::max(3, int(std::lround(options.close_size * std::max(mask.cols, mask.rows))) | 1);
  cv::morphologyEx(mask, mask, cv::MORPH_CLOSE,
                   cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(side, side)));

  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  const double min_area = options.min_area * double(mask.total());
  std::vector<unsigned char> keep(count, 0);
  for (int i = 1; i < count; ++i) keep[i] = stats.at<int>(i, cv::CC_STAT_AREA) >= min_area;
  for (int y = 0; y < mask.rows; ++y)
    for (int x = 0; x < mask.cols; ++x)
      mask.at<unsigned char>(y, x) = keep[labels.at<int>(y, x)] ? 255 : 0;

  // Holes: flood the background from a one-pixel frame around the image.
  cv::Mat padded;
  cv::copyMakeBorder(mask, padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, 0);
  cv::floodFill(padded, cv::Point(0, 0), 128);
  const cv::Mat inner = padded(cv::Rect(1, 1, mask.cols, mask.rows));
  return inner != 128;
}

}  // namespace

std::vector<Image> background_masks(const std::vector<Image>& frames,
                                    const std::vector<std::size_t>& learn,
                                    const MaskOptions& options) {
  if (learn.size() < 2)
    fail("background masks: {} frame(s) to learn from; a background model needs at least 2",
         learn.size());
  for (std::size_t k : learn)
    if (k >= frames.size())
      fail("background masks: frame {} is outside the clip of {}", k, frames.size());
  const int width = frames[0].width, height = frames[0].height;
  std::vector<cv::Mat> bgr;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    if (frames[k].width != width || frames[k].height != height)
      fail("background masks: frame {} is {}x{}, frame 0 {}x{}", k, frames[k].width,
           frames[k].height, width, height);
    bgr.push_back(to_bgr8(frames[k]));
  }

  const cv::Ptr<cv::BackgroundSubtractorMOG2> model =
      cv::createBackgroundSubtractorMOG2(int(learn.size()), options.var_threshold, true);
  model->setBackgroundRatio(options.background_ratio);
  cv::Mat raw;
  for (int pass = 0; pass < 2; ++pass)
    for (std::size_t k : learn) model->apply(bgr[k], raw, -1);  // at rate 1 / min(2 n, history)

  std::vector<Image> masks;
  for (const cv::Mat& frame : bgr) {
    model->apply(frame, raw, 0);  // classify only
    const cv::Mat mask = clean(raw, options);
    Image out(width, height, 1);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) out.at(y, x) = mask.at<unsigned char>(y, x) ? 1.0f : 0.0f;
    masks.push_back(std::move(out));
  }
  return masks;
}

}  // namespace retimegs::prepare
