#include "retimegs/train/dataset.hpp"

namespace retimegs::train {

std::size_t TrainingSet::flow_files() const {
  std::size_t n = 0;
  for (std::size_t c = 0; c < cameras.size(); ++c)
    for (std::size_t i = 0; i < frames.size(); ++i)
      n += forward[c][i].has_value() + backward[c][i].has_value();
  return n;
}

std::size_t TrainingSet::image_bytes() const {
  std::size_t n = 0;
  for (const auto& per_camera : images)
    for (const PackedImage& image : per_camera) n += image.bytes();
  return n;
}

}  // namespace retimegs::train
