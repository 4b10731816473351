#include "retimegs/eval/contact_sheet.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/limits.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"

namespace retimegs::eval {

namespace {

Image to_rgb_tile(const Image& image, int tile_width) {
  const int tile_height =
      std::max(1, int(std::lround(double(image.height) * tile_width / image.width)));
  cv::Mat src(image.height, image.width, CV_32FC(image.channels),
              const_cast<float*>(image.data.data()));
  cv::Mat scaled;
  cv::resize(src, scaled, cv::Size(tile_width, tile_height), 0, 0, cv::INTER_AREA);
  if (image.channels == 1) cv::cvtColor(scaled, scaled, cv::COLOR_GRAY2RGB);
  Image out(tile_width, tile_height, 3);
  std::copy_n(scaled.ptr<float>(), out.data.size(), out.data.data());
  return out;
}

// The caption strip above a tile: `text` in black on white, as large as fits the tile's width
// (OpenCV's Hershey font, scaled with the tile).
Image caption(const std::string& text, int width) {
  constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
  double scale = std::clamp(width / 400.0, 0.3, 0.8);
  int baseline = 0;
  cv::Size size = cv::getTextSize(text, kFont, scale, 1, &baseline);
  if (size.width > width - 4) {  // shrink to fit, down to the smallest legible size
    scale = std::max(0.25, scale * (width - 4) / size.width);
    size = cv::getTextSize(text, kFont, scale, 1, &baseline);
  }
  Image strip(width, size.height + baseline + 6, 3, 1.0f);
  cv::Mat view(strip.height, strip.width, CV_32FC3, strip.data.data());
  cv::putText(view, text, cv::Point(2, 3 + size.height), kFont, scale, cv::Scalar(0, 0, 0), 1,
              cv::LINE_AA);
  return strip;
}

void paste(Image& sheet, const Image& tile, int x0, int y0) {
  for (int y = 0; y < tile.height && y0 + y < sheet.height; ++y)
    for (int x = 0; x < tile.width && x0 + x < sheet.width; ++x)
      for (int c = 0; c < 3; ++c) sheet.at(y0 + y, x0 + x, c) = tile.at(y, x, c);
}

}  // namespace

Image flow_to_color(const Flow& flow, float max_magnitude) {
  float max_mag = max_magnitude;
  if (max_mag <= 0)
    for (std::size_t i = 0; i < flow.pixels(); ++i)
      if (flow.valid[i])
        max_mag = std::max(max_mag, std::hypot(flow.uv[2 * i], flow.uv[2 * i + 1]));
  cv::Mat hsv(flow.height, flow.width, CV_32FC3);
  for (int y = 0; y < flow.height; ++y)
    for (int x = 0; x < flow.width; ++x) {
      const std::size_t i = std::size_t(y) * flow.width + x;
      const float u = flow.uv[2 * i], v = flow.uv[2 * i + 1];
      const float angle = std::atan2(v, u) * float(180 / std::numbers::pi);  // (-180, 180]
      const float saturation = max_mag > 0 ? std::min(1.0f, std::hypot(u, v) / max_mag) : 0.0f;
      hsv.at<cv::Vec3f>(y, x) = {angle < 0 ? angle + 360 : angle, saturation,
                                 flow.valid[i] ? 1.0f : 0.0f};
    }
  cv::Mat rgb;
  cv::cvtColor(hsv, rgb, cv::COLOR_HSV2RGB);
  Image out(flow.width, flow.height, 3);
  std::copy_n(rgb.ptr<float>(), out.data.size(), out.data.data());
  return out;
}

namespace {
// The stride of camera c's flow from frame `from` that the sheet shows: `stride`, or when 0 that
// of the default training (--train-frames even) when the camera has its file, else the shortest
// one it has (1 when none, which shows no flow).
int flow_stride(const io::Scene& scene, int c, int from, int stride) {
  if (stride > 0) return stride;
  const auto has = [&](int k) {
    return from + k < scene.num_frames &&
           std::filesystem::exists(scene.flow_path(c, from, from + k));
  };
  const int trained = io::frame_step(io::FrameSelection::kEven);
  if (has(trained)) return trained;
  for (int k = 1; from + k < scene.num_frames; ++k)
    if (has(k)) return k;
  return 1;
}
}  // namespace

Image contact_sheet(const io::Scene& scene, const SheetOptions& options) {
  if (options.tile_width < kMinOutputSide || options.tile_width > kMaxImageSide)
    fail("--tile-width: {} must lie in [{}, {}] pixels", options.tile_width, kMinOutputSide,
         kMaxImageSide);
  std::vector<int> cameras = options.cameras, frames = options.frames;
  if (cameras.empty()) {
    const int n = int(scene.cameras.size()), rows = std::min(n, 4);
    for (int r = 0; r < rows; ++r) cameras.push_back(r * n / rows);
  }
  if (frames.empty()) {
    frames = {0, scene.num_frames / 2, scene.num_frames - 1};
    frames.erase(std::unique(frames.begin(), frames.end()), frames.end());
  }
  for (int c : cameras)
    if (c < 0 || c >= int(scene.cameras.size())) fail("contact sheet: no camera index {}", c);
  if (options.flow_stride < 0)
    fail("--stride: must be a whole number >= 1, got {}", options.flow_stride);
  for (int k : frames)
    if (k < 0 || k >= scene.num_frames)
      fail("contact sheet: frame {} is outside 0..{}", k, scene.num_frames - 1);

  // Each tile with its caption (camera, frame, and what it shows) above it.
  std::vector<std::vector<Image>> rows;
  for (int c : cameras) {
    std::vector<Image> row;
    const std::string& name = scene.cameras[c].name;
    const auto add = [&](const Image& image, const std::string& what) {
      Image tile = to_rgb_tile(image, options.tile_width);
      if (options.labels) {
        const Image strip = caption(name + " " + what, options.tile_width);
        Image captioned(tile.width, strip.height + tile.height, 3);
        std::copy(strip.data.begin(), strip.data.end(), captioned.data.begin());
        std::copy(tile.data.begin(), tile.data.end(), captioned.data.begin() + strip.data.size());
        tile = std::move(captioned);
      }
      row.push_back(std::move(tile));
    };
    for (int k : frames) {
      add(media::load_image(scene, c, k), fmt::format("frame {}: ground truth", k));
      for (const auto& dir : options.renders)
        add(media::read_image(dir / name / fmt::format("{:05d}.png", k)),
            fmt::format("frame {}: {}", k, output_path(dir).filename().string()));
    }
    if (!options.renders.empty()) {
      rows.push_back(std::move(row));
      continue;
    }
    if (auto mask = media::load_mask(scene, c, frames[0]))
      add(*mask, fmt::format("frame {}: mask", frames[0]));
    const int to = frames[0] + flow_stride(scene, c, frames[0], options.flow_stride);
    if (to < scene.num_frames)
      if (auto flow = io::load_flow(scene, c, frames[0], to))
        add(flow_to_color(*flow), fmt::format("flow {} to {}", frames[0], to));
    rows.push_back(std::move(row));
  }
  std::size_t columns = 0;
  int height = options.gap;
  for (const auto& row : rows) {
    columns = std::max(columns, row.size());
    int row_height = 0;
    for (const auto& tile : row) row_height = std::max(row_height, tile.height);
    height += row_height + options.gap;
  }
  Image sheet(int(columns) * (options.tile_width + options.gap) + options.gap, height, 3, 1.0f);
  int y = options.gap;
  for (const auto& row : rows) {
    int row_height = 0;
    for (std::size_t i = 0; i < row.size(); ++i) {
      paste(sheet, row[i], options.gap + int(i) * (options.tile_width + options.gap), y);
      row_height = std::max(row_height, row[i].height);
    }
    y += row_height + options.gap;
  }
  return sheet;
}

}  // namespace retimegs::eval
