// COLMAP sparse models: binary and text readers, writers (colmap.hpp).
#include "retimegs/io/colmap.hpp"

#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <Eigen/Geometry>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/input_file.hpp"

namespace retimegs::io {
namespace fs = std::filesystem;

namespace {

struct ModelInfo {
  int id;
  const char* name;
  int num_params;
};
// COLMAP's camera model ids (src/base/camera_models.h).
constexpr ModelInfo kModels[] = {
    {0, "SIMPLE_PINHOLE", 3},
    {1, "PINHOLE", 4},
    {2, "SIMPLE_RADIAL", 4},
    {3, "RADIAL", 5},
    {4, "OPENCV", 8},
    {5, "OPENCV_FISHEYE", 8},
    {6, "FULL_OPENCV", 12},
    {7, "FOV", 5},
    {8, "SIMPLE_RADIAL_FISHEYE", 4},
    {9, "RADIAL_FISHEYE", 5},
    {10, "THIN_PRISM_FISHEYE", 12},
};

const ModelInfo* model_by_id(int id) {
  for (const auto& m : kModels)
    if (m.id == id) return &m;
  return nullptr;
}
const ModelInfo* model_by_name(const std::string& name) {
  for (const auto& m : kModels)
    if (name == m.name) return &m;
  return nullptr;
}

// Little-endian binary reader that names the file on truncation.
class BinReader {
 public:
  // check_input_file before the stream opens: opening a FIFO blocks until a writer appears.
  explicit BinReader(const fs::path& path)
      : in_((check_input_file(path, "a COLMAP model file"), path), std::ios::binary),
        name_(path.string()) {
    if (!in_) fail("{}: cannot open COLMAP model file", name_);
    in_.seekg(0, std::ios::end);
    size_ = std::uint64_t(in_.tellg());
    in_.seekg(0);
  }
  template <typename T>
  T get(const char* what) {
    T v;
    if (!in_.read(reinterpret_cast<char*>(&v), sizeof v))
      fail("{}: truncated file (while reading {})", name_, what);
    return v;
  }
  std::string get_string() {
    std::string s;
    for (char c; in_.get(c);) {
      if (c == '\0') return s;
      s += c;
    }
    fail("{}: truncated file (unterminated image name)", name_);
  }
  // A count whose records take at least `min_bytes` each must fit in the rest of the file.
  std::uint64_t get_count(const char* what, std::uint64_t min_bytes) {
    const auto n = get<std::uint64_t>(what);
    const std::uint64_t left = size_ - std::uint64_t(in_.tellg());
    if (min_bytes > 0 && n > left / min_bytes)
      fail("{}: {} {} do not fit in the file (truncated or not a COLMAP model)", name_, n, what);
    return n;
  }
  void expect_end() {
    if (in_.peek() != std::char_traits<char>::eof())
      fail("{}: unexpected data after the last record", name_);
  }
  const std::string& name() const { return name_; }

 private:
  std::ifstream in_;
  std::string name_;
  std::uint64_t size_ = 0;
};

void check_finite(double v, const std::string& file, const std::string& what) {
  if (!std::isfinite(v)) fail("{}: {} is not finite ({})", file, what, v);
}

void check_camera(const ColmapCamera& c, const std::string& file) {
  const ModelInfo* m = model_by_name(c.model);
  if (!m) fail("{}: camera {} has unknown model '{}'", file, c.id, c.model);
  if (int(c.params.size()) != m->num_params)
    fail("{}: camera {} ({}) has {} parameters, the model needs {}", file, c.id, c.model,
         c.params.size(), m->num_params);
  if (c.width < 1 || c.height < 1)
    fail("{}: camera {} has size {}x{}", file, c.id, c.width, c.height);
  for (std::size_t i = 0; i < c.params.size(); ++i)
    check_finite(c.params[i], file, fmt::format("camera {} parameter {}", c.id, i));
}

void check_image(const ColmapImage& im, const std::string& file) {
  for (int i = 0; i < 4; ++i)
    check_finite(im.qvec[i], file, fmt::format("image {} quaternion", im.id));
  for (int i = 0; i < 3; ++i)
    check_finite(im.tvec[i], file, fmt::format("image {} translation", im.id));
  if (im.qvec.norm() < 1e-9) fail("{}: image {} has a zero quaternion", file, im.id);
  if (im.name.empty()) fail("{}: image {} has an empty name", file, im.id);
}

// Lines of a COLMAP text file without comments; `keep_empty` keeps blank lines (images.txt uses
// an empty line for an image without 2-D points).
std::vector<std::pair<int, std::string>> text_lines(const fs::path& path, bool keep_empty) {
  check_input_file(path, "a COLMAP model file");
  std::ifstream in(path);
  if (!in) fail("{}: cannot open COLMAP model file", path.string());
  std::vector<std::pair<int, std::string>> lines;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    if (!line.empty() && line[0] == '#') continue;
    if (line.empty() && !keep_empty) continue;
    lines.emplace_back(number, line);
  }
  return lines;
}

template <typename T>
T parse(std::istringstream& in, const std::string& file, int line, const char* what) {
  T v;
  if (!(in >> v)) fail("{}:{}: cannot read {}", file, line, what);
  return v;
}

std::vector<ColmapCamera> read_cameras_bin(const fs::path& path) {
  BinReader r(path);
  std::vector<ColmapCamera> cams(r.get_count("cameras", 24));
  for (auto& c : cams) {
    c.id = r.get<std::uint32_t>("camera id");
    const int model_id = r.get<std::int32_t>("camera model");
    const ModelInfo* m = model_by_id(model_id);
    if (!m) fail("{}: camera {} has unknown model id {}", r.name(), c.id, model_id);
    c.model = m->name;
    const auto w = r.get<std::uint64_t>("width"), h = r.get<std::uint64_t>("height");
    if (w < 1 || h < 1 || w > 1u << 20 || h > 1u << 20)
      fail("{}: camera {} has size {}x{}", r.name(), c.id, w, h);
    c.width = int(w), c.height = int(h);
    c.params.resize(m->num_params);
    for (double& p : c.params) p = r.get<double>("camera parameters");
  }
  r.expect_end();
  return cams;
}

std::vector<ColmapCamera> read_cameras_txt(const fs::path& path) {
  const std::string file = path.string();
  std::vector<ColmapCamera> cams;
  for (const auto& [number, line] : text_lines(path, false)) {
    std::istringstream in(line);
    ColmapCamera c;
    c.id = parse<std::uint32_t>(in, file, number, "CAMERA_ID");
    c.model = parse<std::string>(in, file, number, "MODEL");
    c.width = parse<int>(in, file, number, "WIDTH");
    c.height = parse<int>(in, file, number, "HEIGHT");
    for (double p; in >> p;) c.params.push_back(p);
    if (!in.eof()) fail("{}:{}: cannot read camera parameters", file, number);
    cams.push_back(std::move(c));
  }
  return cams;
}

std::vector<ColmapImage> read_images_bin(const fs::path& path) {
  BinReader r(path);
  std::vector<ColmapImage> images(r.get_count("images", 4 + 7 * 8 + 4 + 1 + 8));
  for (auto& im : images) {
    im.id = r.get<std::uint32_t>("image id");
    for (int i = 0; i < 4; ++i) im.qvec[i] = r.get<double>("quaternion");
    for (int i = 0; i < 3; ++i) im.tvec[i] = r.get<double>("translation");
    im.camera_id = r.get<std::uint32_t>("camera id");
    im.name = r.get_string();
    const auto n = r.get_count("2-D points", 24);
    for (std::uint64_t i = 0; i < n; ++i) {
      r.get<double>("2-D point"), r.get<double>("2-D point");
      r.get<std::uint64_t>("2-D point's 3-D id");
    }
  }
  r.expect_end();
  return images;
}

std::vector<ColmapImage> read_images_txt(const fs::path& path) {
  const std::string file = path.string();
  const auto lines = text_lines(path, true);
  std::vector<ColmapImage> images;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const auto& [number, line] = lines[i];
    if (line.empty()) continue;
    std::istringstream in(line);
    ColmapImage im;
    im.id = parse<std::uint32_t>(in, file, number, "IMAGE_ID");
    for (int k = 0; k < 4; ++k) im.qvec[k] = parse<double>(in, file, number, "QW QX QY QZ");
    for (int k = 0; k < 3; ++k) im.tvec[k] = parse<double>(in, file, number, "TX TY TZ");
    im.camera_id = parse<std::uint32_t>(in, file, number, "CAMERA_ID");
    std::getline(in >> std::ws, im.name);
    if (im.name.empty()) fail("{}:{}: cannot read NAME", file, number);
    images.push_back(std::move(im));
    ++i;  // the POINTS2D line (possibly empty) that follows every image line
  }
  return images;
}

std::vector<ColmapPoint> read_points_bin(const fs::path& path) {
  BinReader r(path);
  std::vector<ColmapPoint> points(r.get_count("points", 8 + 24 + 3 + 8 + 8));
  for (auto& p : points) {
    p.id = r.get<std::uint64_t>("point id");
    for (int i = 0; i < 3; ++i) p.xyz[i] = r.get<double>("point position");
    for (int i = 0; i < 3; ++i) p.rgb[i] = r.get<std::uint8_t>("point colour");
    p.error = r.get<double>("point error");
    p.track_length = r.get_count("track elements", 8);
    p.track_images.resize(p.track_length);
    for (std::uint64_t i = 0; i < p.track_length; ++i) {
      p.track_images[i] = r.get<std::uint32_t>("track image id");
      r.get<std::uint32_t>("track point index");
    }
  }
  r.expect_end();
  return points;
}

std::vector<ColmapPoint> read_points_txt(const fs::path& path) {
  const std::string file = path.string();
  std::vector<ColmapPoint> points;
  for (const auto& [number, line] : text_lines(path, false)) {
    std::istringstream in(line);
    ColmapPoint p;
    p.id = parse<std::uint64_t>(in, file, number, "POINT3D_ID");
    for (int i = 0; i < 3; ++i) p.xyz[i] = parse<double>(in, file, number, "X Y Z");
    for (int i = 0; i < 3; ++i) {
      const int c = parse<int>(in, file, number, "R G B");
      if (c < 0 || c > 255) fail("{}:{}: colour {} outside 0..255", file, number, c);
      p.rgb[i] = std::uint8_t(c);
    }
    p.error = parse<double>(in, file, number, "ERROR");
    std::size_t track = 0;
    for (std::uint64_t v; in >> v;) {
      if (track % 2 == 0) p.track_images.push_back(std::uint32_t(v));  // IMAGE_ID POINT2D_IDX
      ++track;
    }
    if (!in.eof() || track % 2) fail("{}:{}: malformed TRACK", file, number);
    p.track_length = track / 2;
    points.push_back(p);
  }
  return points;
}

// dir/name.bin when present, else dir/name.txt; empty when neither exists.
fs::path model_file(const fs::path& dir, const std::string& name) {
  if (fs::exists(dir / (name + ".bin"))) return dir / (name + ".bin");
  if (fs::exists(dir / (name + ".txt"))) return dir / (name + ".txt");
  return {};
}

bool is_bin(const fs::path& p) {
  return p.extension() == ".bin";
}

}  // namespace

int colmap_model_num_params(const std::string& model) {
  const ModelInfo* m = model_by_name(model);
  return m ? m->num_params : -1;
}

Eigen::Matrix4d ColmapImage::world_to_camera() const {
  const Eigen::Quaterniond q(qvec[0], qvec[1], qvec[2], qvec[3]);
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = q.normalized().toRotationMatrix();
  m.topRightCorner<3, 1>() = tvec;
  return m;
}

ColmapImage ColmapImage::from_world_to_camera(std::uint32_t id, std::uint32_t camera_id,
                                              std::string name, const Eigen::Matrix4d& w2c) {
  ColmapImage im;
  im.id = id, im.camera_id = camera_id, im.name = std::move(name);
  Eigen::Quaterniond q(Eigen::Matrix3d(w2c.topLeftCorner<3, 3>()));
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1;  // COLMAP writes qw >= 0
  im.qvec = {q.w(), q.x(), q.y(), q.z()};
  im.tvec = w2c.topRightCorner<3, 1>();
  return im;
}

const ColmapCamera& ColmapModel::camera(std::uint32_t id) const {
  for (const auto& c : cameras)
    if (c.id == id) return c;
  fail("COLMAP model: no camera with id {}", id);
}

PointCloud ColmapModel::point_cloud() const {
  PointCloud cloud;
  cloud.xyz.reserve(points.size() * 3);
  cloud.rgb.reserve(points.size() * 3);
  for (const auto& p : points)
    for (int i = 0; i < 3; ++i) {
      cloud.xyz.push_back(float(p.xyz[i]));
      cloud.rgb.push_back(p.rgb[i] / 255.0f);
    }
  return cloud;
}

fs::path find_colmap_model(const fs::path& dir) {
  for (const fs::path& d : {dir, dir / "sparse" / "0", dir / "sparse"})
    if (!model_file(d, "cameras").empty()) return d;
  fail("{}: no COLMAP sparse model (cameras.bin / cameras.txt) here, in sparse/0 or in sparse",
       dir.string());
}

ColmapModel read_colmap_model(const fs::path& dir) {
  if (!fs::is_directory(dir)) fail("{}: COLMAP model folder does not exist", dir.string());
  const fs::path cameras = model_file(dir, "cameras"), images = model_file(dir, "images"),
                 points = model_file(dir, "points3D");
  if (cameras.empty()) fail("{}: missing cameras.bin / cameras.txt", dir.string());
  if (images.empty()) fail("{}: missing images.bin / images.txt", dir.string());
  ColmapModel model;
  model.cameras = is_bin(cameras) ? read_cameras_bin(cameras) : read_cameras_txt(cameras);
  model.images = is_bin(images) ? read_images_bin(images) : read_images_txt(images);
  if (!points.empty())
    model.points = is_bin(points) ? read_points_bin(points) : read_points_txt(points);

  std::set<std::uint32_t> camera_ids, image_ids;
  for (const auto& c : model.cameras) {
    check_camera(c, cameras.string());
    if (!camera_ids.insert(c.id).second)
      fail("{}: camera id {} appears twice", cameras.string(), c.id);
  }
  std::set<std::string> names;
  for (const auto& im : model.images) {
    check_image(im, images.string());
    if (!image_ids.insert(im.id).second)
      fail("{}: image id {} appears twice", images.string(), im.id);
    if (!names.insert(im.name).second)
      fail("{}: image name '{}' appears twice", images.string(), im.name);
    if (!camera_ids.count(im.camera_id))
      fail("{}: image {} ('{}') refers to camera {}, which {} does not define", images.string(),
           im.id, im.name, im.camera_id, cameras.filename().string());
  }
  for (const auto& p : model.points)
    for (int i = 0; i < 3; ++i)
      check_finite(p.xyz[i], points.string(), fmt::format("point {} position", p.id));
  return model;
}

void write_colmap_model_txt(const ColmapModel& model, const fs::path& dir) {
  fs::create_directories(dir);
  auto write = [&](const std::string& name, const std::string& text) {
    write_text_file(dir / name, text);
  };
  std::string cams =
      "# Camera list with one line of data per camera:\n"
      "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n";
  for (const auto& c : model.cameras) {
    cams += fmt::format("{} {} {} {}", c.id, c.model, c.width, c.height);
    for (double p : c.params) cams += fmt::format(" {:.17g}", p);
    cams += '\n';
  }
  std::string images =
      "# Image list with two lines of data per image:\n"
      "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
      "#   POINTS2D[] as (X, Y, POINT3D_ID)\n";
  for (const auto& im : model.images)
    images += fmt::format("{} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {} {}\n\n",
                          im.id, im.qvec[0], im.qvec[1], im.qvec[2], im.qvec[3], im.tvec[0],
                          im.tvec[1], im.tvec[2], im.camera_id, im.name);
  std::string points =
      "# 3D point list with one line of data per point:\n"
      "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, "
      "POINT2D_IDX)\n";
  for (const auto& p : model.points)
    points += fmt::format("{} {:.17g} {:.17g} {:.17g} {} {} {} {:.17g}\n", p.id, p.xyz[0], p.xyz[1],
                          p.xyz[2], p.rgb[0], p.rgb[1], p.rgb[2], p.error);
  write("cameras.txt", cams);
  write("images.txt", images);
  write("points3D.txt", points);
}

void write_colmap_model_bin(const ColmapModel& model, const fs::path& dir) {
  fs::create_directories(dir);
  auto write = [&](const std::string& name, const std::string& bytes) {
    write_text_file(dir / name, bytes);
  };
  auto put = [](std::string& s, auto v) { s.append(reinterpret_cast<const char*>(&v), sizeof v); };
  std::string cams, images, points;
  put(cams, std::uint64_t(model.cameras.size()));
  for (const auto& c : model.cameras) {
    const ModelInfo* m = model_by_name(c.model);
    if (!m) fail("write_colmap_model_bin: unknown camera model '{}'", c.model);
    put(cams, c.id), put(cams, std::int32_t(m->id));
    put(cams, std::uint64_t(c.width)), put(cams, std::uint64_t(c.height));
    for (double p : c.params) put(cams, p);
  }
  put(images, std::uint64_t(model.images.size()));
  for (const auto& im : model.images) {
    put(images, im.id);
    for (int i = 0; i < 4; ++i) put(images, im.qvec[i]);
    for (int i = 0; i < 3; ++i) put(images, im.tvec[i]);
    put(images, im.camera_id);
    images += im.name;
    images += '\0';
    put(images, std::uint64_t(0));  // no 2-D points
  }
  put(points, std::uint64_t(model.points.size()));
  for (const auto& p : model.points) {
    put(points, p.id);
    for (int i = 0; i < 3; ++i) put(points, p.xyz[i]);
    for (int i = 0; i < 3; ++i) put(points, p.rgb[i]);
    put(points, p.error);
    put(points, std::uint64_t(0));  // empty track
  }
  write("cameras.bin", cams);
  write("images.bin", images);
  write("points3D.bin", points);
}

}  // namespace retimegs::io
