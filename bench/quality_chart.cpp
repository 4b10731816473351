// Bar chart of the quality benchmark: reads the CSV of bench/quality.sh (preset, variant, psnr,
// ssim, lpips, then the whole-image figures, stability and train_seconds) and draws the masked PSNR
// per variant, one group of bars per preset.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: quality_chart RESULTS.csv OUT.png\n");
    return 2;
  }
  std::ifstream in(argv[1]);
  std::string line;
  std::getline(in, line);  // header
  std::vector<std::string> presets, variants;
  std::map<std::pair<std::string, std::string>, double> psnr;
  double lo = 1e9, hi = -1e9;
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string preset, variant, value;
    std::getline(ss, preset, ',');
    std::getline(ss, variant, ',');
    std::getline(ss, value, ',');
    const double p = std::stod(value);
    if (std::find(presets.begin(), presets.end(), preset) == presets.end())
      presets.push_back(preset);
    if (std::find(variants.begin(), variants.end(), variant) == variants.end())
      variants.push_back(variant);
    psnr[{preset, variant}] = p;
    lo = std::min(lo, p), hi = std::max(hi, p);
  }
  if (presets.empty()) {
    std::fprintf(stderr, "quality_chart: %s holds no results\n", argv[1]);
    return 2;
  }
  const double floor_db = std::floor(lo - 2), top_db = std::ceil(hi + 1);
  const int bar = 26, gap = 40, left = 60, height = 420, bottom = 120;
  const int width = left + int(presets.size()) * (int(variants.size()) * bar + gap) + 20;
  cv::Mat img(height + bottom, width, CV_8UC3, cv::Scalar(255, 255, 255));
  auto y_of = [&](double db) {
    return int(height - (db - floor_db) / (top_db - floor_db) * (height - 40));
  };
  for (double db = floor_db; db <= top_db; db += 1) {
    cv::line(img, {left, y_of(db)}, {width - 10, y_of(db)}, cv::Scalar(225, 225, 225));
    cv::putText(img, std::to_string(int(db)), {8, y_of(db) + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.4,
                cv::Scalar(0, 0, 0));
  }
  cv::putText(img, "held-out PSNR (dB)", {left, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.55,
              cv::Scalar(0, 0, 0));
  int x = left;
  for (const auto& preset : presets) {
    for (std::size_t v = 0; v < variants.size(); ++v) {
      const auto it = psnr.find({preset, variants[v]});
      if (it != psnr.end()) {
        const cv::Scalar colour = variants[v] == "full"   ? cv::Scalar(60, 140, 30)
                                  : variants[v] == "stgs" ? cv::Scalar(40, 40, 200)
                                  : (variants[v] == "crossfade" || variants[v] == "nearest")
                                      ? cv::Scalar(150, 150, 150)
                                      : cv::Scalar(200, 130, 40);
        cv::rectangle(img, {x + 3, y_of(it->second)}, {x + bar - 3, height}, colour, cv::FILLED);
      }
      cv::Mat label(20, 110, CV_8UC3, cv::Scalar(255, 255, 255));
      cv::putText(label, variants[v], {2, 14}, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0));
      cv::rotate(label, label, cv::ROTATE_90_COUNTERCLOCKWISE);
      label.copyTo(img(cv::Rect(x + 4, height + 4, 20, 110)));
      x += bar;
    }
    cv::putText(img, preset, {x - int(variants.size()) * bar / 2 - 20, 40},
                cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0));
    x += gap;
  }
  if (!cv::imwrite(argv[2], img)) {
    std::fprintf(stderr, "quality_chart: cannot write %s\n", argv[2]);
    return 2;
  }
  return 0;
}
