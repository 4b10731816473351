#pragma once
// A Camera's projection in the scalar type of a computation (float in training and rendering,
// double in the references), and its derivatives, written once for every stage that projects.
// The member templates take the point's coordinates as V: T itself, or a vector of T (the
// renderer's simd lanes), with the same operations in the same order for both. The numbers are
// plain arrays, the member templates RETIMEGS_HD and the header free of Eigen, so that the CUDA
// kernels project with this same code (a PinholeT passed by value to a kernel).
#include "retimegs/core/hd.hpp"

namespace retimegs {

struct Camera;

// The results of PinholeT's functions, as named fields (structured bindings work on both devices;
// std::array's accessors are host-only for nvcc).
template <typename V>
struct Point3T {
  V x, y, z;
};
template <typename V>
struct Pixel2T {
  V u, v;
};

// d(u, v) / d(x, y, z) of PinholeT::project at a camera-space point: [[j00, 0, j02],
// [0, j11, j12]] (u depends on x and z only, v on y and z only).
template <typename V>
struct PinholeJacobianT {
  V j00, j02, j11, j12;
};

template <typename T>
struct PinholeT {
  T rotation[9]{};  // [3, 3] world -> camera, row-major
  T translation[3]{};
  T fx = 0, fy = 0, cx = 0, cy = 0;
  int width = 0, height = 0;

  PinholeT() = default;
  explicit PinholeT(const Camera& camera);  // core/pinhole.cpp (float and double)

  // Camera-space point of the world point (x, y, z): rotation * (x, y, z) + translation. Kept as
  // a loop over the rows: g++ contracts this form into the fused multiply-adds that the CPU's
  // float training results are pinned with (an unrolled expression contracts differently).
  template <typename V>
  RETIMEGS_HD Point3T<V> to_camera(V x, V y, V z) const {
    V p[3];
    for (int i = 0; i < 3; ++i)
      p[i] =
          rotation[3 * i] * x + rotation[3 * i + 1] * y + rotation[3 * i + 2] * z + translation[i];
    return {p[0], p[1], p[2]};
  }

  // Continuous pixel coordinates (u, v) of the camera-space point (x, y, z), z > 0 (pixel
  // centres at +0.5, core/camera.hpp).
  template <typename V>
  RETIMEGS_HD Pixel2T<V> project(V x, V y, V z) const {
    return {fx * x / z + cx, fy * y / z + cy};
  }

  // d(u, v) / d(x, y, z) of project at the camera-space point (x, y, z).
  template <typename V>
  RETIMEGS_HD PinholeJacobianT<V> jacobian(V x, V y, V z) const {
    return {fx / z, -fx * x / (z * z), fy / z, -fy * y / (z * z)};
  }

  // Vector-Jacobian product of jacobian: d loss / d (x, y, z) given d loss / d of its entries.
  template <typename V>
  RETIMEGS_HD Point3T<V> jacobian_vjp(V x, V y, V z, const PinholeJacobianT<V>& v_jac) const {
    const V rz = T(1) / z, rz2 = rz * rz, rz3 = rz2 * rz;
    return {-fx * rz2 * v_jac.j02, -fy * rz2 * v_jac.j12,
            -fx * rz2 * v_jac.j00 - fy * rz2 * v_jac.j11 + 2 * fx * x * rz3 * v_jac.j02 +
                2 * fy * y * rz3 * v_jac.j12};
  }
};

}  // namespace retimegs
