// Calibrations of `import videos` (calibration.hpp): COLMAP models and OpenCV-style rig files.
#include "calibration.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <initializer_list>
#include <set>
#include <sstream>
#include <string_view>

#include <fmt/format.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "retimegs/core/camera.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/input_file.hpp"
#include "retimegs/ingest/rig_file.hpp"

namespace retimegs::ingest::detail {
namespace fs = std::filesystem;

namespace {

constexpr double kOpenCvToColmap = 0.5;  // pixel-centre convention shift of the principal point

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

// A field's numbers in row-major order with the shape they were written in: a scalar (1x1), a
// flat sequence (1xN), a sequence of equal-length sequences (RxC) or an !!opencv-matrix.
struct Numbers {
  int rows = 0, cols = 0;
  std::vector<double> values;
  bool flat() const { return rows == 1 || cols == 1; }
};

double scalar(const cv::FileNode& node, const std::string& where, const std::string& field) {
  if (!node.isInt() && !node.isReal())
    fail("{}: '{}' must hold numbers, got '{}'", where, field,
         node.isString() ? node.string() : std::string("a map or sequence"));
  return double(node);
}

Numbers numbers(const cv::FileNode& node, const std::string& where, const std::string& field) {
  Numbers out;
  if (node.isMap()) {
    // !!opencv-matrix (YAML) / {"type_id": "opencv-matrix", ...} (JSON): rows, cols, dt, data.
    if (node["data"].empty() || node["rows"].empty() || node["cols"].empty())
      fail("{}: '{}' must be numbers or an !!opencv-matrix (rows, cols, dt, data)", where, field);
    // OpenCV allocates rows x cols before it counts 'data': the declared size is checked against
    // the numbers given first, so that a few bytes cannot ask for gigabytes.
    const cv::FileNode rows = node["rows"], cols = node["cols"], data = node["data"];
    if (!rows.isInt() || !cols.isInt() || int(rows) < 1 || int(cols) < 1)
      fail("{}: '{}' rows and cols must be positive integers", where, field);
    const std::size_t given = data.isSeq() ? data.size() : 1;
    if (std::size_t(int(rows)) * std::size_t(int(cols)) != given)
      fail("{}: '{}' is declared {}x{} but its data holds {} number{}", where, field, int(rows),
           int(cols), given, given == 1 ? "" : "s");
    cv::Mat m;
    try {
      node >> m;
    } catch (const cv::Exception& e) {
      fail("{}: '{}' is not a readable !!opencv-matrix ({})", where, field, e.err);
    }
    if (m.empty() || m.channels() != 1)
      fail("{}: '{}' must be a one-channel !!opencv-matrix with data", where, field);
    m.convertTo(m, CV_64F);
    out.rows = m.rows, out.cols = m.cols;
    for (int r = 0; r < m.rows; ++r)
      for (int c = 0; c < m.cols; ++c) out.values.push_back(m.at<double>(r, c));
  } else if (node.isSeq()) {
    const int n = int(node.size());
    if (n > 0 && node[0].isSeq()) {
      out.rows = n, out.cols = int(node[0].size());
      for (int r = 0; r < n; ++r) {
        const cv::FileNode row = node[r];
        if (!row.isSeq() || int(row.size()) != out.cols)
          fail("{}: '{}' rows must all hold {} numbers (row {} does not)", where, field, out.cols,
               r);
        for (int c = 0; c < out.cols; ++c) out.values.push_back(scalar(row[c], where, field));
      }
    } else {
      out.rows = 1, out.cols = n;
      for (int i = 0; i < n; ++i) out.values.push_back(scalar(node[i], where, field));
    }
  } else {
    out.rows = out.cols = 1;
    out.values.push_back(scalar(node, where, field));
  }
  for (double v : out.values)
    if (!std::isfinite(v)) fail("{}: '{}' has a non-finite value ({})", where, field, v);
  return out;
}

// The node of a field that may go by several names (the first is the documented one); `used` is
// set to the name found. Two of the names at once are an error.
cv::FileNode field(const cv::FileNode& camera, std::initializer_list<const char*> names,
                   const std::string& where, std::string& used) {
  cv::FileNode found;
  used = *names.begin();
  for (const char* name : names) {
    const cv::FileNode node = camera[name];
    if (node.isNone()) continue;
    if (!found.isNone())
      fail("{}: both '{}' and '{}' are given (they are aliases)", where, used, name);
    found = node, used = name;
  }
  return found;
}

// 3x3 (or 9 numbers) and 3-vector fields.
Eigen::Matrix3d matrix3(const cv::FileNode& node, const std::string& where,
                        const std::string& name) {
  const Numbers n = numbers(node, where, name);
  if (n.values.size() != 9 || !((n.rows == 3 && n.cols == 3) || n.flat()))
    fail("{}: '{}' must be 3x3 (or 9 numbers), got {}x{}", where, name, n.rows, n.cols);
  Eigen::Matrix3d m;
  for (int i = 0; i < 9; ++i) m(i / 3, i % 3) = n.values[i];
  return m;
}

Eigen::Vector3d vector3(const cv::FileNode& node, const std::string& where,
                        const std::string& name) {
  const Numbers n = numbers(node, where, name);
  if (n.values.size() != 3 || !n.flat())
    fail("{}: '{}' must be 3 numbers, got {}x{}", where, name, n.rows, n.cols);
  return {n.values[0], n.values[1], n.values[2]};
}

int positive_int(const cv::FileNode& node, const std::string& where, const std::string& name) {
  const double v = scalar(node, where, name);
  if (!(v >= 1 && v <= 1 << 20) || v != std::floor(v))
    fail("{}: '{}' must be a positive integer, got {}", where, name, v);
  return int(v);
}

// Pixel size from width / height or image_size: [w, h]; 0 x 0 when absent.
std::pair<int, int> image_size(const cv::FileNode& camera, const std::string& where) {
  const cv::FileNode w = camera["width"], h = camera["height"], size = camera["image_size"];
  const bool has_wh = !w.isNone() || !h.isNone();
  if (has_wh && !size.isNone())
    fail("{}: give either 'width' / 'height' or 'image_size', not both", where);
  if (has_wh) {
    if (w.isNone() || h.isNone()) fail("{}: 'width' and 'height' go together", where);
    return {positive_int(w, where, "width"), positive_int(h, where, "height")};
  }
  if (size.isNone()) return {0, 0};
  if (!size.isSeq() || size.size() != 2) fail("{}: 'image_size' must be [width, height]", where);
  return {positive_int(size[0], where, "image_size"), positive_int(size[1], where, "image_size")};
}

CalibratedCamera read_rig_camera(const cv::FileNode& node, const std::string& name,
                                 const std::string& file) {
  CalibratedCamera cam;
  cam.name = name;
  cam.where = fmt::format("{}: camera '{}'", file, name);
  const std::string& where = cam.where;
  if (!node.isMap()) fail("{}: must be a map with K, dist, R, t", where);
  std::string used;

  // K: [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]; skew is not a pinhole camera of the scene format.
  const cv::FileNode k_node = field(node, {"K", "camera_matrix"}, where, used);
  if (k_node.isNone()) fail("{}: missing 'K' (or 'camera_matrix')", where);
  const Eigen::Matrix3d k = matrix3(k_node, where, used);
  const double fx = k(0, 0), fy = k(1, 1), cx = k(0, 2), cy = k(1, 2);
  if (!(fx > 0 && fy > 0))
    fail("{}: '{}' focal lengths must be positive, got fx {} fy {}", where, used, fx, fy);
  constexpr double kZero = 1e-9;  // relative to fx: calibration tools write exact zeros
  if (std::abs(k(0, 1)) > kZero * fx || std::abs(k(1, 0)) > kZero * fx ||
      std::abs(k(2, 0)) > kZero || std::abs(k(2, 1)) > kZero || std::abs(k(2, 2) - 1) > kZero)
    fail(
        "{}: '{}' must be [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (no skew), got [[{}, {}, {}], "
        "[{}, {}, {}], [{}, {}, {}]]",
        where, used, k(0, 0), k(0, 1), k(0, 2), k(1, 0), k(1, 1), k(1, 2), k(2, 0), k(2, 1),
        k(2, 2));

  // model and distortion
  std::string model = "pinhole";
  const cv::FileNode model_node = node["model"];
  if (!model_node.isNone()) {
    if (!model_node.isString()) fail("{}: 'model' must be pinhole or fisheye", where);
    model = lower(model_node.string());
    if (model != "pinhole" && model != "fisheye")
      fail("{}: 'model' must be pinhole or fisheye, got '{}'", where, model_node.string());
  }
  std::vector<double> dist;
  const cv::FileNode d_node = field(node, {"dist", "distortion_coefficients", "D"}, where, used);
  if (!d_node.isNone()) {
    const Numbers d = numbers(d_node, where, used);
    if (!d.flat())
      fail("{}: '{}' must be a list of numbers, got {}x{}", where, used, d.rows, d.cols);
    dist = d.values;
    const std::size_t n = dist.size();
    if (n > 8)
      fail("{}: '{}' has {} coefficients; at most 8 are supported (k1 k2 p1 p2 k3 k4 k5 k6)", where,
           used, n);
    if (model == "fisheye" && n != 0 && n != 4)
      fail("{}: '{}' of a fisheye camera must have 4 coefficients (k1 k2 k3 k4), got {}", where,
           used, n);
    if (model == "pinhole" && n != 0 && n != 4 && n != 5 && n != 8)
      fail("{}: '{}' must have 0, 4, 5 or 8 coefficients (k1 k2 p1 p2 [k3 [k4 k5 k6]]), got {}",
           where, used, n);
  }
  // The equivalent COLMAP model: OPENCV is k1 k2 p1 p2; FULL_OPENCV adds k3 k4 k5 k6 (OpenCV's
  // order); OPENCV_FISHEYE is k1..k4 on the angle. Zero coefficients of a pinhole are PINHOLE.
  // OpenCV puts the centre of the top-left pixel at (0, 0), COLMAP and the scene format at
  // (0.5, 0.5): the principal point moves by half a pixel.
  io::ColmapCamera& c = cam.intrinsics;
  c.params = {fx, fy, cx + kOpenCvToColmap, cy + kOpenCvToColmap};
  const bool any = std::any_of(dist.begin(), dist.end(), [](double v) { return v != 0.0; });
  if (model == "fisheye") {
    c.model = "OPENCV_FISHEYE";
    dist.resize(4, 0.0);
  } else if (!any) {
    c.model = "PINHOLE";
    dist.clear();
  } else if (dist.size() == 4 || (dist.size() == 5 && dist[4] == 0.0)) {
    c.model = "OPENCV";
    dist.resize(4);
  } else {
    c.model = "FULL_OPENCV";
    dist.resize(8, 0.0);
  }
  c.params.insert(c.params.end(), dist.begin(), dist.end());
  std::tie(c.width, c.height) = image_size(node, where);

  // Pose: x_cam = R x_world + t.
  Eigen::Matrix3d r;
  const cv::FileNode r_node = field(node, {"R", "rvec"}, where, used);
  if (r_node.isNone()) fail("{}: missing 'R' (or 'rvec')", where);
  const std::string r_name = used;
  if (used == "rvec") {
    const Eigen::Vector3d v = vector3(r_node, where, used);
    cv::Mat rvec = (cv::Mat_<double>(3, 1) << v.x(), v.y(), v.z()), rmat;
    cv::Rodrigues(rvec, rmat);
    for (int i = 0; i < 9; ++i) r(i / 3, i % 3) = rmat.at<double>(i / 3, i % 3);
  } else {
    r = matrix3(r_node, where, used);
  }
  const cv::FileNode t_node = field(node, {"t", "T", "tvec"}, where, used);
  if (t_node.isNone()) fail("{}: missing 't' (or 'T', 'tvec')", where);
  const Eigen::Vector3d t = vector3(t_node, where, used);
  cam.world_to_camera.topLeftCorner<3, 3>() = r;
  cam.world_to_camera.topRightCorner<3, 1>() = t;
  check_rigid(cam.world_to_camera, fmt::format("{}: '{}'", where, r_name));
  return cam;
}

// OpenCV's parse errors read "... in function '<name>(<line>): <problem>'": the line and the
// problem are what the user needs. `shift` lines were prepended to the file's text.
std::string parse_problem(const cv::Exception& e, int shift) {
  const std::string& m = e.msg;
  const std::size_t start = m.find("in function '"), end = m.rfind('\'');
  if (start == std::string::npos || end == std::string::npos || end <= start + 13) return e.err;
  const std::string what = m.substr(start + 13, end - start - 13);
  const std::size_t close = what.find("): ");
  const std::size_t open = close == std::string::npos ? close : what.rfind('(', close);
  if (open == std::string::npos) return what;
  const int line = std::atoi(what.substr(open + 1, close - open - 1).c_str()) - shift;
  return fmt::format("line {}: {}", line, what.substr(close + 3));
}

// OpenCV 4.6's YAML parser loops forever when text follows the first top-level collection and
// starts with '-' (not "---"): after a collection that ends early (a flow [..] / {..}, a block
// that a less indented line ends, "...") it skips three characters and then never advances
// (fuzzing found " T:]\n1, -\n:"). A rig's top level is a block map ('cameras:'): its first
// line starts at column 0 and no line starts with "...", so that the map runs to the end.
void check_yaml_top_level(std::string_view text, const std::string& file) {
  bool first = true;
  for (std::size_t at = 0; at < text.size();) {
    std::size_t end = text.find('\n', at);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(at, end - at);
    at = end + 1;
    if (line.rfind("...", 0) == 0)
      fail("{}: cannot parse the rig file (a line starts with '...': one YAML document expected)",
           file);
    const std::size_t content = line.find_first_not_of(" \t\r");
    const bool document_start =  // "---" alone on its line
        line.rfind("---", 0) == 0 && line.find_first_not_of(" \t\r", 3) == std::string_view::npos;
    if (!first || content == std::string_view::npos || line[content] == '#' ||
        line[content] == '%' || document_start)
      continue;
    first = false;
    if (content != 0 || line[0] == '-' || line[0] == '[' || line[0] == '{')
      fail(
          "{}: cannot parse the rig file (its top level must be a map, 'cameras:' at the start "
          "of a line)",
          file);
  }
}

// The rig's text parsed from memory (cv::FileStorage::MEMORY), so that read_rig and the fuzzing
// harness share one path. OpenCV's YAML parser needs the "%YAML:1.0" first line, which
// hand-written files lack: it is prepended then.
cv::FileStorage open_rig(std::string_view text, bool json, const std::string& file) {
  // OpenCV's parsers read a NUL as the end of the text and report an empty file as "invalid":
  // both are refused here with their own message.
  if (text.find('\0') != std::string_view::npos)
    fail("{}: cannot parse the rig file (it holds a NUL byte: not a text file)", file);
  if (text.find_first_not_of(" \t\r\n") == std::string_view::npos)
    fail("{}: the rig file is empty", file);
  if (!json) check_yaml_top_level(text, file);
  const bool prepend = !json && text.rfind("%YAML", 0) != 0;
  const std::string content = (prepend ? "%YAML:1.0\n" : "") + std::string(text);
  cv::FileStorage storage;
  try {
    storage.open(content, cv::FileStorage::READ | cv::FileStorage::MEMORY |
                              (json ? cv::FileStorage::FORMAT_JSON : cv::FileStorage::FORMAT_YAML));
  } catch (const cv::Exception& e) {
    fail("{}: cannot parse the rig file ({})", file, parse_problem(e, prepend ? 1 : 0));
  } catch (const std::exception& e) {
    // OpenCV's parsers let standard exceptions through on some malformed texts (fuzzing found a
    // std::length_error from a YAML file cut short inside a flow sequence).
    fail("{}: cannot parse the rig file ({})", file, e.what());
  }
  if (!storage.isOpened()) fail("{}: cannot parse the rig file", file);
  return storage;
}

// A map key as written: OpenCV keeps the quotes of a quoted YAML key.
std::string unquoted(std::string key) {
  if (key.size() >= 2 && (key.front() == '"' || key.front() == '\'') && key.back() == key.front())
    key = key.substr(1, key.size() - 2);
  return key;
}

}  // namespace

std::vector<CalibratedCamera> read_rig(const fs::path& path) {
  const std::string file = path.string();
  return read_rig_text(read_text_file(path, "the rig file"),
                       lower(path.extension().string()) == ".json", file);
}

std::vector<CalibratedCamera> read_rig_text(std::string_view text, bool json,
                                            const std::string& file) {
  cv::FileStorage storage = open_rig(text, json, file);
  std::vector<CalibratedCamera> out;
  try {
    // FileStorage::operator[] asserts that the top level is a map: a file holding a sequence or
    // a scalar is told apart first.
    const cv::FileNode root = storage.root();
    const cv::FileNode cameras = root.isMap() ? root["cameras"] : cv::FileNode();
    if (cameras.isMap()) {
      for (auto it = cameras.begin(); it != cameras.end(); ++it)
        out.push_back(read_rig_camera(*it, unquoted((*it).name()), file));
    } else if (cameras.isSeq()) {
      for (int i = 0; i < int(cameras.size()); ++i) {
        const cv::FileNode node = cameras[i];
        const cv::FileNode name = node.isMap() ? node["name"] : cv::FileNode();
        if (!name.isString() || name.string().empty())
          fail("{}: cameras[{}]: 'name' must be a non-empty string (quote numbers: name: \"07\")",
               file, i);
        out.push_back(read_rig_camera(node, name.string(), file));
      }
    } else {
      fail(
          "{}: missing top-level 'cameras' (a map keyed by camera name, or a sequence of maps "
          "with 'name')",
          file);
    }
  } catch (const cv::Exception& e) {
    fail("{}: cannot read the rig file ({})", file, e.err);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {  // as in open_rig
    fail("{}: cannot read the rig file ({})", file, e.what());
  }
  if (out.empty()) fail("{}: 'cameras' is empty", file);
  std::set<std::string> names;
  for (const CalibratedCamera& cam : out)
    if (!names.insert(cam.name).second) fail("{}: camera '{}' appears twice", file, cam.name);
  return out;
}

std::vector<CalibratedCamera> read_colmap_calibration(const fs::path& dir) {
  const fs::path model_dir = io::find_colmap_model(dir);
  io::ColmapModel model = io::read_colmap_model(model_dir);
  if (model.images.empty()) fail("{}: the COLMAP model has no images", model_dir.string());
  std::sort(model.images.begin(), model.images.end(),
            [](const io::ColmapImage& a, const io::ColmapImage& b) { return a.name < b.name; });
  std::vector<CalibratedCamera> out;
  for (const io::ColmapImage& im : model.images) {
    CalibratedCamera cam;
    cam.name = fs::path(im.name).stem().string();
    cam.where =
        fmt::format("{}: image '{}' (camera {})", model_dir.string(), im.name, im.camera_id);
    cam.intrinsics = model.camera(im.camera_id);
    cam.world_to_camera = im.world_to_camera();
    check_rigid(cam.world_to_camera, cam.where);
    out.push_back(std::move(cam));
  }
  return out;
}

std::vector<CalibratedCamera> read_calibration(const fs::path& path) {
  if (fs::is_directory(path)) return read_colmap_calibration(path);
  const std::string ext = lower(path.extension().string());
  if (ext == ".yaml" || ext == ".yml" || ext == ".json") {
    if (!fs::is_regular_file(path)) fail("{}: rig file does not exist", path.string());
    return read_rig(path);
  }
  if (!fs::exists(path))
    fail("{}: calibration does not exist (a COLMAP model folder or a rig .yaml / .yml / .json)",
         path.string());
  fail("{}: a calibration is a COLMAP model folder or a rig file (.yaml, .yml, .json)",
       path.string());
}

io::ColmapCamera fit_to_footage(io::ColmapCamera cam, int width, int height,
                                const std::string& where, const std::string& footage) {
  if (cam.width == 0 && cam.height == 0) {
    cam.width = width, cam.height = height;
    return cam;
  }
  if (cam.width == width && cam.height == height) return cam;
  const double sx = double(width) / cam.width, sy = double(height) / cam.height;
  if (std::abs(sx - sy) > 0.01 * std::max(sx, sy))
    fail("{}: footage is {}x{} but {} is calibrated for {}x{} (a different aspect ratio)", footage,
         width, height, where, cam.width, cam.height);
  // Focal lengths and principal point scale with the image; distortion acts on normalised
  // coordinates and stays. Single-focal models hold f, cx, cy; the others fx, fy, cx, cy.
  auto& p = cam.params;
  static const std::set<std::string> kSingleFocal = {"SIMPLE_PINHOLE", "SIMPLE_RADIAL", "RADIAL",
                                                     "SIMPLE_RADIAL_FISHEYE", "RADIAL_FISHEYE"};
  if (kSingleFocal.count(cam.model) && p.size() >= 3) {
    p[0] *= 0.5 * (sx + sy), p[1] *= sx, p[2] *= sy;
  } else if (p.size() >= 4) {
    p[0] *= sx, p[1] *= sy, p[2] *= sx, p[3] *= sy;
  }
  cam.width = width, cam.height = height;
  return cam;
}

}  // namespace retimegs::ingest::detail

namespace retimegs::ingest {

std::vector<Camera> read_rig_cameras(const std::filesystem::path& file) {
  std::vector<Camera> cameras;
  for (const detail::CalibratedCamera& c : detail::read_rig(file)) {
    const io::ColmapCamera& k = c.intrinsics;
    if (k.model != "PINHOLE")
      fail("{}: has distortion ({}): only a pinhole camera is a scene camera as it is", c.where,
           k.model);
    if (k.width == 0) fail("{}: no 'width' and 'height': the rig gives no image size", c.where);
    Camera cam;
    cam.name = c.name;
    cam.width = k.width, cam.height = k.height;
    cam.fx = k.params[0], cam.fy = k.params[1], cam.cx = k.params[2], cam.cy = k.params[3];
    cam.world_to_camera = c.world_to_camera;
    cameras.push_back(std::move(cam));
  }
  return cameras;
}

}  // namespace retimegs::ingest
