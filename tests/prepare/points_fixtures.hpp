#pragma once
// What the prepare tests share: a synthetic ring scene written to disk, and the distance from a
// point to the nearest point of a cloud.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <utility>
#include <vector>

#include <nanoflann.hpp>

#include "retimegs/io/scene.hpp"
#include "retimegs/media/scene_images.hpp"
#include "retimegs/synth/synth.hpp"

namespace retimegs::test {

// synth's "minimal" preset: `cameras` on a ring, `frames` frames at width x height.
inline io::Scene minimal_scene(const std::filesystem::path& root, int cameras, int width,
                               int height, int frames = 3) {
  synth::SynthOptions options;
  options.preset = "minimal";
  options.cameras = cameras;
  options.frames = frames;
  options.width = width, options.height = height;
  options.progress = false;
  synth::synthesize_scene(options, root);
  return media::read_scene(root);
}

// Distance from each query point to the nearest point of `xyz` ([N, 3], k-d tree).
class Nearest {
 public:
  explicit Nearest(const std::vector<float>& xyz)
      : cloud_{xyz}, tree_(3, cloud_, nanoflann::KDTreeSingleIndexAdaptorParams(16)) {
    tree_.buildIndex();
  }
  double distance(const float* q) const { return std::sqrt(double(nearest(q).second)); }
  std::pair<std::uint32_t, float> nearest(const float* q) const {
    std::uint32_t id = 0;
    float d2 = 0;
    tree_.knnSearch(q, 1, &id, &d2);
    return {id, d2};
  }

 private:
  struct Cloud {
    const std::vector<float>& xyz;
    std::size_t kdtree_get_point_count() const { return xyz.size() / 3; }
    float kdtree_get_pt(std::size_t i, std::size_t d) const { return xyz[3 * i + d]; }
    template <class B>
    bool kdtree_get_bbox(B&) const {
      return false;
    }
  };
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Cloud>,
                                                   Cloud, 3, std::uint32_t>;
  Cloud cloud_;
  Tree tree_;
};

}  // namespace retimegs::test
