#pragma once
// A Camera's projection in the scalar type of a computation (float in training and rendering,
// double in the references), and its derivatives, written once for every stage that projects.
// The member templates take the point's coordinates as V: T itself, or a vector of T (the
// renderer's simd lanes), with the same operations in the same order for both.
#include <array>

#include <Eigen/Core>

#include "retimegs/core/camera.hpp"

namespace retimegs {

// d(u, v) / d(x, y, z) of PinholeT::project at a camera-space point: [[j00, 0, j02],
// [0, j11, j12]] (u depends on x and z only, v on y and z only).
template <typename V>
struct PinholeJacobianT {
  V j00, j02, j11, j12;

  Eigen::Matrix<V, 2, 3> matrix() const {
    Eigen::Matrix<V, 2, 3> m;
    m << j00, V(0), j02, V(0), j11, j12;
    return m;
  }
};

template <typename T>
struct PinholeT {
  std::array<T, 9> rotation{};  // [3, 3] world -> camera, row-major
  std::array<T, 3> translation{};
  T fx = 0, fy = 0, cx = 0, cy = 0;
  int width = 0, height = 0;

  PinholeT() = default;
  explicit PinholeT(const Camera& camera)
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

  // Camera-space point of the world point (x, y, z): rotation * (x, y, z) + translation.
  template <typename V>
  std::array<V, 3> to_camera(V x, V y, V z) const {
    std::array<V, 3> p;
    for (int i = 0; i < 3; ++i)
      p[i] =
          rotation[3 * i] * x + rotation[3 * i + 1] * y + rotation[3 * i + 2] * z + translation[i];
    return p;
  }

  // Continuous pixel coordinates (u, v) of the camera-space point (x, y, z), z > 0 (pixel
  // centres at +0.5, core/camera.hpp).
  template <typename V>
  std::array<V, 2> project(V x, V y, V z) const {
    return {fx * x / z + cx, fy * y / z + cy};
  }

  // d(u, v) / d(x, y, z) of project at the camera-space point (x, y, z).
  template <typename V>
  PinholeJacobianT<V> jacobian(V x, V y, V z) const {
    return {fx / z, -fx * x / (z * z), fy / z, -fy * y / (z * z)};
  }

  // Vector-Jacobian product of jacobian: d loss / d (x, y, z) given d loss / d of its entries.
  template <typename V>
  std::array<V, 3> jacobian_vjp(V x, V y, V z, const PinholeJacobianT<V>& v_jac) const {
    const V rz = T(1) / z, rz2 = rz * rz, rz3 = rz2 * rz;
    return {-fx * rz2 * v_jac.j02, -fy * rz2 * v_jac.j12,
            -fx * rz2 * v_jac.j00 - fy * rz2 * v_jac.j11 + 2 * fx * x * rz3 * v_jac.j02 +
                2 * fy * y * rz3 * v_jac.j12};
  }
};

}  // namespace retimegs
