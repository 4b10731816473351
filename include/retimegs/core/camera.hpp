#pragma once
// Pinhole camera in the OpenCV convention (docs/formats.md): x right, y down, z forward;
// world_to_camera is a rigid 4x4 transform; the centre of pixel (row i, column j) is at
// continuous image coordinates (j + 0.5, i + 0.5).
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace retimegs {

enum class Split { kTrain, kTest };

struct Camera {
  std::string name;
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  Eigen::Matrix4d world_to_camera = Eigen::Matrix4d::Identity();
  Split split = Split::kTrain;

  Eigen::Matrix3d rotation() const { return world_to_camera.topLeftCorner<3, 3>(); }
  Eigen::Vector3d translation() const { return world_to_camera.topRightCorner<3, 1>(); }
  // Camera centre in world coordinates: -R^T t.
  Eigen::Vector3d center() const { return -rotation().transpose() * translation(); }

  Eigen::Vector3d world_to_cam(const Eigen::Vector3d& x_world) const {
    return rotation() * x_world + translation();
  }
  Eigen::Vector3d cam_to_world(const Eigen::Vector3d& x_cam) const {
    return rotation().transpose() * (x_cam - translation());
  }
  // Continuous pixel coordinates (u, v) of a camera-space point; z must be > 0.
  Eigen::Vector2d project_cam(const Eigen::Vector3d& x_cam) const {
    return {fx * x_cam.x() / x_cam.z() + cx, fy * x_cam.y() / x_cam.z() + cy};
  }
  Eigen::Vector2d project(const Eigen::Vector3d& x_world) const {
    return project_cam(world_to_cam(x_world));
  }
  // World point at camera depth z (along the optical axis) seen at pixel coordinates (u, v).
  Eigen::Vector3d unproject(const Eigen::Vector2d& uv, double depth) const {
    return cam_to_world({(uv.x() - cx) / fx * depth, (uv.y() - cy) / fy * depth, depth});
  }
  // Unit ray direction in world space through pixel coordinates (u, v).
  Eigen::Vector3d ray_direction(const Eigen::Vector2d& uv) const {
    Eigen::Vector3d d_cam((uv.x() - cx) / fx, (uv.y() - cy) / fy, 1.0);
    return (rotation().transpose() * d_cam).normalized();
  }
  bool in_image(const Eigen::Vector2d& uv) const {
    return uv.x() >= 0 && uv.y() >= 0 && uv.x() < width && uv.y() < height;
  }
};

// The same view at another image size: focal lengths and principal point scaled per axis by
// width / camera.width and height / camera.height, so the image spans the same field of view
// (continuous image coordinates scale with the grid). Throws Error unless both sizes are > 0.
Camera resized(Camera camera, int width, int height);

// Checks a downscale factor (import --downscale, train --downscale): throws Error naming
// --downscale unless it is finite and >= 1.
void check_downscale(double downscale);

// The camera with its image size divided by `downscale` (each side rounded, at least 1 pixel) and
// its intrinsics following (resized). Throws Error as check_downscale does.
Camera downscaled(Camera camera, double downscale);

// A camera at `eye` looking at `target` with the given world "up" direction (OpenCV axes:
// the camera's -y axis is as close to `up` as possible).
Eigen::Matrix4d look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                        const Eigen::Vector3d& up);

// Throws Error naming `what` unless m is finite with an orthonormal, det +1 rotation block and
// last row (0, 0, 0, 1). Tolerance on R^T R - I and det - 1.
void check_rigid(const Eigen::Matrix4d& m, const std::string& what, double tolerance = 1e-4);

// The world-to-camera matrix (OpenCV axes) of a camera-to-world matrix with OpenGL / Blender
// camera axes (x right, y up, z backward), as nerfstudio, instant-ngp and Blender write them:
// OpenCV's camera-to-world is camera_to_world * diag(1, -1, -1, 1). The rotation block must be
// orthonormal (check_rigid first); the result is its exact rigid inverse.
Eigen::Matrix4d world_to_camera_from_opengl(const Eigen::Matrix4d& camera_to_world);

}  // namespace retimegs
