#include "retimegs/io/npy.hpp"

#include <bit>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/input_file.hpp"

namespace retimegs::io {
namespace fs = std::filesystem;

static_assert(std::endian::native == std::endian::little, ".npy I/O assumes a little-endian host");

namespace {

constexpr char kMagic[] = "\x93NUMPY";  // 6 bytes, then major and minor version
constexpr std::size_t kAlign = 64;      // numpy pads the header so that the data is 64-aligned

// Index of the value of `key` in the header dict ({'descr': '<f4', ...}).
std::size_t value_at(const std::string& dict, const std::string& key, const std::string& name) {
  for (const char quote : {'\'', '"'}) {
    const std::size_t k = dict.find(quote + key + quote);
    if (k == std::string::npos) continue;
    const std::size_t colon = dict.find_first_not_of(' ', k + key.size() + 2);
    if (colon == std::string::npos || dict[colon] != ':') break;
    const std::size_t value = dict.find_first_not_of(' ', colon + 1);
    if (value != std::string::npos) return value;
  }
  fail("{}: malformed .npy header (no '{}' entry)", name, key);
}

std::vector<std::size_t> parse_shape(const std::string& dict, const std::string& name) {
  const std::size_t open = value_at(dict, "shape", name), close = dict.find(')', open);
  if (dict[open] != '(' || close == std::string::npos)
    fail("{}: malformed .npy header (shape is not a tuple)", name);
  std::vector<std::size_t> shape;
  const char* p = dict.data() + open + 1;
  const char* end = dict.data() + close;
  while (p < end) {
    while (p < end && *p == ' ') ++p;
    if (p == end) break;
    std::size_t dim = 0;
    const auto [next, ec] = std::from_chars(p, end, dim);
    if (ec != std::errc()) fail("{}: malformed .npy header (bad shape)", name);
    shape.push_back(dim);
    p = next;
    while (p < end && *p == ' ') ++p;
    if (p < end && *p++ != ',') fail("{}: malformed .npy header (bad shape)", name);
  }
  return shape;
}

template <typename T>
void convert(const char* bytes, std::vector<double>& values) {
  for (std::size_t i = 0; i < values.size(); ++i) {
    T v;
    std::memcpy(&v, bytes + i * sizeof(T), sizeof(T));
    values[i] = double(v);
  }
}

}  // namespace

std::vector<float> NpyArray::to_float() const {
  return {values.begin(), values.end()};
}

std::vector<std::int32_t> NpyArray::to_int() const {
  std::vector<std::int32_t> out(values.size());
  for (std::size_t i = 0; i < values.size(); ++i) {
    const double v = values[i];
    if (!(v == std::floor(v) && v >= INT32_MIN && v <= INT32_MAX))
      fail(".npy value {} at index {} is not an int32", v, i);
    out[i] = std::int32_t(v);
  }
  return out;
}

NpyArray read_npy(const fs::path& path) {
  const std::string name = path.string();
  check_input_file(path, "a .npy file");
  if (!fs::is_regular_file(path)) fail("{}: no such file", name);
  std::string file(fs::file_size(path), '\0');
  std::ifstream in(path, std::ios::binary);
  if (!in.read(file.data(), std::streamsize(file.size()))) fail("{}: cannot read file", name);
  if (file.size() < 10 || file.compare(0, 6, kMagic) != 0)
    fail("{}: not a .npy file (bad magic)", name);
  const int major = static_cast<unsigned char>(file[6]);
  if (major < 1 || major > 3) fail("{}: unsupported .npy version {}", name, major);
  const std::size_t prefix = major == 1 ? 10 : 12;  // v1: uint16 header length, v2/v3: uint32
  if (file.size() < prefix) fail("{}: truncated .npy header", name);
  std::uint32_t header_len = 0;
  std::memcpy(&header_len, file.data() + 8, prefix - 8);
  const std::size_t data_start = prefix + header_len;
  if (file.size() < data_start) fail("{}: truncated .npy header", name);
  const std::string dict = file.substr(prefix, header_len);

  NpyArray array;
  const std::size_t d = value_at(dict, "descr", name);
  const std::size_t d_end = dict.find(dict[d], d + 1);
  if ((dict[d] != '\'' && dict[d] != '"') || d_end == std::string::npos)
    fail("{}: malformed .npy header (descr is not a string)", name);
  const std::string descr = dict.substr(d + 1, d_end - d - 1);
  if (descr == "<f4")
    array.type = NpyArray::Type::kFloat32;
  else if (descr == "<f8")
    array.type = NpyArray::Type::kFloat64;
  else if (descr == "<i4")
    array.type = NpyArray::Type::kInt32;
  else if (descr.starts_with('>'))
    fail("{}: big-endian dtype '{}' is not supported", name, descr);
  else
    fail("{}: unsupported dtype '{}' (expected <f4, <f8 or <i4)", name, descr);
  const std::size_t f = value_at(dict, "fortran_order", name);
  if (dict.compare(f, 4, "True") == 0) fail("{}: Fortran-order arrays are not supported", name);
  if (dict.compare(f, 5, "False") != 0)
    fail("{}: malformed .npy header (fortran_order is not True or False)", name);
  array.shape = parse_shape(dict, name);
  const std::size_t item = array.type == NpyArray::Type::kFloat64 ? 8 : 4;

  std::size_t count = 1;
  for (const std::size_t dim : array.shape) {
    if (dim != 0 && count > std::numeric_limits<std::size_t>::max() / item / dim)
      fail("{}: .npy shape is too large", name);
    count *= dim;
  }
  const std::size_t expected = count * item, found = file.size() - data_start;
  if (found < expected)
    fail("{}: truncated .npy body (expected {} bytes, found {})", name, expected, found);
  array.values.resize(count);
  const char* bytes = file.data() + data_start;
  switch (array.type) {
    case NpyArray::Type::kFloat32:
      convert<float>(bytes, array.values);
      break;
    case NpyArray::Type::kFloat64:
      convert<double>(bytes, array.values);
      break;
    case NpyArray::Type::kInt32:
      convert<std::int32_t>(bytes, array.values);
      break;
  }
  return array;
}

void write_npy(const fs::path& path, const std::vector<std::size_t>& shape,
               const std::vector<float>& values) {
  std::size_t count = 1;
  std::string dims;
  for (const std::size_t dim : shape) {
    count *= dim;
    dims += fmt::format("{}, ", dim);
  }
  if (count != values.size())
    fail("{}: shape ({}) holds {} values, not {}", path.string(), dims, count, values.size());
  if (shape.size() > 1)
    dims.resize(dims.size() - 2);  // Python tuples: (3,) but (2, 3)
  else if (shape.size() == 1)
    dims.pop_back();
  std::string header =
      fmt::format("{{'descr': '<f4', 'fortran_order': False, 'shape': ({}), }}", dims);
  header.append((kAlign - (10 + header.size() + 1) % kAlign) % kAlign, ' ');  // 10: magic + len
  header += '\n';
  const std::uint16_t header_len = std::uint16_t(header.size());

  AtomicFile file(path);
  errno = 0;
  std::ofstream out(file.temp_path(), std::ios::binary);
  out.write(kMagic, 6).write("\x01\x00", 2);
  out.write(reinterpret_cast<const char*>(&header_len), 2) << header;
  out.write(reinterpret_cast<const char*>(values.data()), std::streamsize(values.size() * 4));
  out.close();
  check_written(out, path);
  file.commit();
}

}  // namespace retimegs::io
