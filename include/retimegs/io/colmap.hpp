#pragma once
// COLMAP sparse models (cameras, images, points3D as .bin or .txt, COLMAP 3.x layout). COLMAP's
// command line is run by colmap/run.hpp (for `prepare --points colmap` and `import videos`
// without a calibration). COLMAP conventions: the quaternion (qw, qx, qy, qz) and translation of an
// image map world to camera; pixel centres are at integer + 0.5 (as in the scene format).
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "retimegs/io/ply.hpp"
#include "retimegs/io/scene.hpp"

namespace retimegs::io {

struct ColmapCamera {
  std::uint32_t id = 0;
  std::string model;  // "SIMPLE_PINHOLE", "PINHOLE", "SIMPLE_RADIAL", "RADIAL", "OPENCV", ...
  int width = 0, height = 0;
  std::vector<double> params;  // COLMAP's order for the model, e.g. PINHOLE: fx, fy, cx, cy
};

struct ColmapImage {
  std::uint32_t id = 0;
  Eigen::Vector4d qvec{1, 0, 0, 0};  // (qw, qx, qy, qz) world-to-camera rotation
  Eigen::Vector3d tvec{0, 0, 0};     // world-to-camera translation
  std::uint32_t camera_id = 0;
  std::string name;  // path relative to the image folder

  Eigen::Matrix4d world_to_camera() const;  // normalises the quaternion
  static ColmapImage from_world_to_camera(std::uint32_t id, std::uint32_t camera_id,
                                          std::string name, const Eigen::Matrix4d& w2c);
};

struct ColmapPoint {
  std::uint64_t id = 0;
  Eigen::Vector3d xyz{0, 0, 0};
  std::array<std::uint8_t, 3> rgb{0, 0, 0};
  double error = 0;
  std::uint64_t track_length = 0;  // observations
  // [track_length] the image id of each observation, where the file gives them (read, not
  // written: write_colmap_model writes empty tracks).
  std::vector<std::uint32_t> track_images;
};

struct ColmapModel {
  std::vector<ColmapCamera> cameras;  // in file order
  std::vector<ColmapImage> images;    // in file order
  std::vector<ColmapPoint> points;    // in file order

  // Throws Error when absent.
  const ColmapCamera& camera(std::uint32_t id) const;
  PointCloud point_cloud() const;  // xyz + rgb in [0, 1]
};

// Number of parameters of a COLMAP camera model; -1 for an unknown name.
int colmap_model_num_params(const std::string& model);

// Reads dir/cameras.bin, images.bin, points3D.bin, or the .txt files where no .bin exists
// (points3D may be absent: no points). Validates counts, parameter counts, finite numbers, unique
// ids and that every image's camera exists; throws Error naming the file and the record.
ColmapModel read_colmap_model(const std::filesystem::path& dir);

// The sparse-model folder of a COLMAP project: dir itself when it holds cameras.{bin,txt}, else
// dir/sparse/0, else dir/sparse. Throws Error naming dir when none does.
std::filesystem::path find_colmap_model(const std::filesystem::path& dir);

// Writes cameras.txt, images.txt (empty 2-D point lines) and points3D.txt (empty tracks) into dir
// (created if needed), full double precision.
void write_colmap_model_txt(const ColmapModel& model, const std::filesystem::path& dir);
// The same in COLMAP's binary layout (tests of the binary reader).
void write_colmap_model_bin(const ColmapModel& model, const std::filesystem::path& dir);

}  // namespace retimegs::io
