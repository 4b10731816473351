#pragma once
// k-nearest-neighbour queries over a 3-D point set (nanoflann k-d tree), for initial scales and
// dynamic stretching.
#include <cstdint>
#include <memory>
#include <vector>

namespace retimegs::train {

class PointIndex {
 public:
  // points: [N, 3], kept by reference — it must outlive the index.
  explicit PointIndex(const std::vector<float>& points);
  ~PointIndex();
  PointIndex(const PointIndex&) = delete;
  PointIndex& operator=(const PointIndex&) = delete;

  // Up to k nearest points to `query` (nearest first); returns how many were found.
  int knn(const float query[3], int k, std::uint32_t* indices, float* squared_distances) const;

 private:
  struct Tree;
  std::unique_ptr<Tree> tree_;
};

// 3DGS initial scale: sqrt of the mean squared distance to the 3 nearest other points, per point
// ([N]); a lone point gets `fallback`.
std::vector<float> mean_neighbor_distance(const std::vector<float>& points, float fallback);

}  // namespace retimegs::train
