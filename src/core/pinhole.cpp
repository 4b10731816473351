// PinholeT's constructor from a Camera, here so that pinhole.hpp stays free of Eigen (nvcc
// compiles it into the CUDA kernels).
#include "retimegs/core/pinhole.hpp"

#include "retimegs/core/camera.hpp"

namespace retimegs {

template <typename T>
PinholeT<T>::PinholeT(const Camera& camera)
    : fx(T(camera.fx)),
      fy(T(camera.fy)),
      cx(T(camera.cx)),
      cy(T(camera.cy)),
      width(camera.width),
      height(camera.height) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) rotation[3 * r + c] = T(camera.world_to_camera(r, c));
    translation[r] = T(camera.world_to_camera(r, 3));
  }
}

template struct PinholeT<float>;
template struct PinholeT<double>;

}  // namespace retimegs
