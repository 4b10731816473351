#include "retimegs/io/ply.hpp"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/input_file.hpp"
#include "retimegs/core/interrupt.hpp"

namespace retimegs::io {
namespace fs = std::filesystem;

static_assert(std::endian::native == std::endian::little, "PLY I/O assumes a little-endian host");

namespace {

enum class Scalar { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

struct ScalarName {
  const char* name;
  const char* alias;
  Scalar type;
  int size;
};
constexpr ScalarName kScalars[] = {
    {"char", "int8", Scalar::kInt8, 1},        {"uchar", "uint8", Scalar::kUint8, 1},
    {"short", "int16", Scalar::kInt16, 2},     {"ushort", "uint16", Scalar::kUint16, 2},
    {"int", "int32", Scalar::kInt32, 4},       {"uint", "uint32", Scalar::kUint32, 4},
    {"float", "float32", Scalar::kFloat32, 4}, {"double", "float64", Scalar::kFloat64, 8}};

int size_of(Scalar t) {
  return kScalars[int(t)].size;
}

enum class Format { kAscii, kBinaryLittle, kBinaryBig };

struct Property {
  std::string name;
  Scalar type = Scalar::kFloat32;
  bool is_list = false;
  Scalar count_type = Scalar::kUint8;  // lists only
};

struct Element {
  std::string name;
  std::size_t count = 0;
  std::vector<Property> properties;
  std::size_t row_bytes() const {  // binary rows without lists
    std::size_t n = 0;
    for (const Property& p : properties) n += size_of(p.type);
    return n;
  }
};

struct Header {
  Format format = Format::kAscii;
  std::vector<Element> elements;
};

// The fewest bytes one row of `e` takes: binary scalars their size, a list at least its count;
// in ASCII every value at least one digit and one separator.
std::size_t min_row_bytes(const Element& e, Format format) {
  if (format == Format::kAscii) return 2 * e.properties.size();
  std::size_t n = 0;
  for (const Property& p : e.properties) n += size_of(p.is_list ? p.count_type : p.type);
  return n;
}

// Sizes declared in the header are checked against the bytes that follow it before anything is
// allocated or looped over: a 62-byte file must not announce 10^9 vertices.
void check_counts(const Header& header, std::size_t last, std::uintmax_t body_bytes,
                  const std::string& name) {
  std::uintmax_t needed = 0;
  for (std::size_t i = 0; i <= last; ++i) {
    const Element& e = header.elements[i];
    if (e.properties.empty()) {
      if (e.count > 0)
        fail("{}: PLY element '{}' declares {} rows but no properties", name, e.name, e.count);
      continue;
    }
    const std::size_t row = min_row_bytes(e, header.format);
    const bool fixed_rows = header.format != Format::kAscii &&
                            std::none_of(e.properties.begin(), e.properties.end(),
                                         [](const Property& p) { return p.is_list; });
    if (fixed_rows && i == last) break;  // read_vertex_table checks it exactly, naming the row
    // +1: the last ASCII value needs no separator after it.
    if (e.count > (body_bytes + 1 - std::min(needed, body_bytes)) / row)
      fail(
          "{}: PLY element '{}' declares {} rows, more than the {} bytes after the header can "
          "hold (truncated or corrupted)",
          name, e.name, e.count, body_bytes);
    needed += e.count * row;
  }
}

// One binary scalar, byte-swapped first when the file is big-endian.
template <typename T>
double as(const char* p, bool swap) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, p, sizeof(T));
  if (swap) std::reverse(b, b + sizeof(T));
  T v;
  std::memcpy(&v, b, sizeof(T));
  return double(v);
}

double load(const char* p, Scalar t, bool swap) {
  switch (t) {
    case Scalar::kInt8:
      return as<std::int8_t>(p, swap);
    case Scalar::kUint8:
      return as<std::uint8_t>(p, swap);
    case Scalar::kInt16:
      return as<std::int16_t>(p, swap);
    case Scalar::kUint16:
      return as<std::uint16_t>(p, swap);
    case Scalar::kInt32:
      return as<std::int32_t>(p, swap);
    case Scalar::kUint32:
      return as<std::uint32_t>(p, swap);
    case Scalar::kFloat32:
      return as<float>(p, swap);
    case Scalar::kFloat64:
      return as<double>(p, swap);
  }
  return 0;
}

Header parse_header(std::istream& in, const std::string& name) {
  std::string line;
  std::getline(in, line);
  if (line != "ply" && line != "ply\r") fail("{}: not a PLY file (first line is not 'ply')", name);
  Header header;
  bool has_format = false;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword.empty() || keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "end_header") {
      if (!has_format) fail("{}: PLY header has no format line", name);
      return header;
    }
    auto scalar = [&](const std::string& word) {
      for (const ScalarName& s : kScalars)
        if (word == s.name || word == s.alias) return s.type;
      fail("{}: unknown PLY property type '{}'", name, word);
    };
    if (keyword == "format") {
      std::string format, version;
      words >> format >> version;
      if (version != "1.0") fail("{}: unsupported PLY version '{}'", name, version);
      if (format == "ascii")
        header.format = Format::kAscii;
      else if (format == "binary_little_endian")
        header.format = Format::kBinaryLittle;
      else if (format == "binary_big_endian")
        header.format = Format::kBinaryBig;
      else
        fail("{}: unknown PLY format '{}'", name, format);
      has_format = true;
    } else if (keyword == "element") {
      Element element;
      std::string count;
      words >> element.name >> count;
      const auto [end, ec] =
          std::from_chars(count.data(), count.data() + count.size(), element.count);
      if (element.name.empty() || ec != std::errc() || end != count.data() + count.size())
        fail("{}: malformed PLY element line '{}'", name, line);
      header.elements.push_back(std::move(element));
    } else if (keyword == "property") {
      if (header.elements.empty()) fail("{}: PLY property before any element", name);
      Property p;
      std::string type;
      words >> type;
      if (type == "list") {
        std::string count_type, item_type;
        words >> count_type >> item_type;
        p.is_list = true;
        p.count_type = scalar(count_type);
        type = item_type;
      }
      p.type = scalar(type);
      words >> p.name;
      if (p.name.empty()) fail("{}: malformed PLY property line '{}'", name, line);
      header.elements.back().properties.push_back(std::move(p));
    } else {
      fail("{}: unexpected PLY header line '{}'", name, line);
    }
  }
  fail("{}: PLY header has no end_header line", name);
}

// ASCII body: whitespace-separated numbers. Returns false at the end of the file.
bool next_ascii(std::istream& in, double& value, const std::string& name) {
  std::string token;
  if (!(in >> token)) return false;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc() || end != token.data() + token.size())
    fail("{}: malformed number '{}' in PLY body", name, token);
  return true;
}

// Reads past the rows of an element that is not the vertex table.
void skip_element(std::istream& in, const Element& e, Format format, std::uintmax_t file_size,
                  const std::string& name) {
  auto truncated = [&](std::size_t row) {
    fail("{}: truncated PLY body (element '{}' row {} of {})", name, e.name, row, e.count);
  };
  const bool has_list = std::any_of(e.properties.begin(), e.properties.end(),
                                    [](const Property& p) { return p.is_list; });
  if (format != Format::kAscii && !has_list) {
    const std::uintmax_t left = file_size - std::uintmax_t(in.tellg());
    const std::size_t row = e.row_bytes();
    if (row > 0 && left / row < e.count) truncated(left / row);
    in.seekg(std::streamoff(row * e.count), std::ios::cur);
    return;
  }
  double value = 0;
  char buffer[8];
  auto scalar = [&](Scalar t) {  // the next scalar of the row, as a count for lists
    if (format == Format::kAscii) return next_ascii(in, value, name);
    if (!in.read(buffer, size_of(t))) return false;
    value = load(buffer, t, format == Format::kBinaryBig);
    return true;
  };
  for (std::size_t row = 0; row < e.count; ++row)
    for (const Property& p : e.properties) {
      if (!p.is_list) {
        if (!scalar(p.type)) truncated(row);
        continue;
      }
      if (!scalar(p.count_type)) truncated(row);
      if (!(value >= 0) || value != std::floor(value) || value > double(file_size))
        fail("{}: invalid list length {} in PLY element '{}' row {}", name, value, e.name, row);
      for (std::size_t k = 0, n = std::size_t(value); k < n; ++k)
        if (!scalar(p.type)) truncated(row);
    }
}

struct VertexTable {
  PlyTable table;
  std::vector<Scalar> types;  // per column
};

VertexTable read_vertex_table(const fs::path& path) {
  const std::string name = path.string();
  check_input_file(path, "a PLY file");
  if (!fs::is_regular_file(path)) fail("{}: no such file", name);
  const std::uintmax_t file_size = fs::file_size(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) fail("{}: cannot open file", name);
  const Header header = parse_header(in, name);
  // A header that ends the file leaves the stream at EOF, where tellg() fails.
  const std::streamoff header_end = in.tellg();
  const std::uintmax_t body_bytes =
      header_end < 0 ? 0 : file_size - std::min<std::uintmax_t>(file_size, header_end);

  const auto vertex = std::find_if(header.elements.begin(), header.elements.end(),
                                   [](const Element& e) { return e.name == "vertex"; });
  if (vertex == header.elements.end()) fail("{}: PLY file has no vertex element", name);
  check_counts(header, std::size_t(vertex - header.elements.begin()), body_bytes, name);
  VertexTable out;
  PlyTable& table = out.table;
  for (const Property& p : vertex->properties) {
    if (p.is_list)
      fail("{}: list property '{}' in the PLY vertex element is not supported", name, p.name);
    table.names.push_back(p.name);
    out.types.push_back(p.type);
  }
  // Later elements (faces, edges) are never read.
  for (auto e = header.elements.begin(); e != vertex; ++e)
    skip_element(in, *e, header.format, file_size, name);

  const std::size_t n = vertex->count, columns = table.names.size();
  auto truncated = [&](std::size_t i) {
    fail("{}: truncated PLY body (vertex {} of {})", name, i, n);
  };
  if (header.format == Format::kAscii) {
    table.columns.resize(columns);
    double value = 0;
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t c = 0; c < columns; ++c) {
        if (!next_ascii(in, value, name)) truncated(i);
        table.columns[c].push_back(float(value));
      }
  } else {
    const std::size_t row = vertex->row_bytes();
    const std::uintmax_t left = file_size - std::uintmax_t(in.tellg());
    if (row > 0 && left / row < n) truncated(left / row);
    table.columns.assign(columns, std::vector<float>(n));
    std::vector<char> bytes(row * n);
    in.read(bytes.data(), std::streamsize(bytes.size()));
    if (!in) fail("{}: cannot read PLY body", name);
    const bool swap = header.format == Format::kBinaryBig;
    const char* p = bytes.data();
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t c = 0; c < columns; ++c) {
        table.columns[c][i] = float(load(p, out.types[c], swap));
        p += size_of(out.types[c]);
      }
  }
  table.count = n;
  return out;
}

}  // namespace

bool PlyTable::has(const std::string& name) const {
  return std::find(names.begin(), names.end(), name) != names.end();
}

const std::vector<float>& PlyTable::column(const std::string& name) const {
  const auto it = std::find(names.begin(), names.end(), name);
  if (it == names.end()) fail("PLY table has no column '{}'", name);
  return columns[it - names.begin()];
}

void PlyTable::add(const std::string& name, std::vector<float> values) {
  if (has(name)) fail("PLY table already has a column '{}'", name);
  if (names.empty()) count = values.size();
  if (values.size() != count)
    fail("PLY column '{}' has {} values, the table has {} rows", name, values.size(), count);
  names.push_back(name);
  columns.push_back(std::move(values));
}

PlyTable read_ply(const fs::path& path) {
  return read_vertex_table(path).table;
}

void write_ply(const fs::path& path, const PlyTable& table, bool replace) {
  const std::string name = path.string();
  if (table.names.size() != table.columns.size())
    fail("{}: PLY table has {} names but {} columns", name, table.names.size(),
         table.columns.size());
  std::string header = fmt::format(
      "ply\nformat binary_little_endian 1.0\ncomment retimegs\nelement vertex {}\n", table.count);
  std::vector<bool> is_colour;
  for (std::size_t c = 0; c < table.names.size(); ++c) {
    const std::string& column = table.names[c];
    if (column.empty() || column.find_first_of(" \t\r\n") != std::string::npos)
      fail("{}: invalid PLY property name '{}'", name, column);
    if (table.columns[c].size() != table.count)
      fail("{}: PLY column '{}' has {} values, the table has {} rows", name, column,
           table.columns[c].size(), table.count);
    is_colour.push_back(column == "red" || column == "green" || column == "blue");
    header += fmt::format("property {} {}\n", is_colour.back() ? "uchar" : "float", column);
  }
  header += "end_header\n";

  AtomicFile file(path, replace);
  errno = 0;
  std::ofstream out(file.temp_path(), std::ios::binary);
  out << header;
  std::vector<char> row;
  for (std::size_t i = 0; i < table.count; ++i) {
    throw_if_interrupted_every(i);  // Ctrl-C: `file` removes the unfinished temporary
    row.clear();
    for (std::size_t c = 0; c < table.columns.size(); ++c) {
      const float v = table.columns[c][i];
      if (is_colour[c]) {
        row.push_back(char(std::uint8_t(std::lround(v > 0 ? (v < 255 ? v : 255) : 0))));
      } else {
        const char* bytes = reinterpret_cast<const char*>(&v);
        row.insert(row.end(), bytes, bytes + 4);
      }
    }
    out.write(row.data(), std::streamsize(row.size()));
  }
  out.close();
  check_written(out, path);
  file.commit();
}

PointCloud read_points_ply(const fs::path& path) {
  const std::string name = path.string();
  const VertexTable vt = read_vertex_table(path);
  const PlyTable& table = vt.table;
  for (const char* axis : {"x", "y", "z"})
    if (!table.has(axis)) fail("{}: PLY vertex element has no '{}' property", name, axis);
  PointCloud points;
  points.xyz.resize(3 * table.count);
  const std::vector<float>* xyz[] = {&table.column("x"), &table.column("y"), &table.column("z")};
  for (std::size_t i = 0; i < table.count; ++i)
    for (int k = 0; k < 3; ++k) {
      const float v = (*xyz[k])[i];
      if (!std::isfinite(v)) fail("{}: non-finite coordinate {} at vertex {}", name, v, i);
      points.xyz[3 * i + k] = v;
    }

  const char* channels[] = {"red", "green", "blue"};
  const int present = int(table.has("red")) + table.has("green") + table.has("blue");
  if (present == 0) return points;
  if (present != 3) fail("{}: PLY vertex colour needs all of red, green, blue", name);
  points.rgb.resize(3 * table.count);
  for (int k = 0; k < 3; ++k) {
    const std::size_t c =
        std::find(table.names.begin(), table.names.end(), channels[k]) - table.names.begin();
    float scale = 1.0f;  // float / double colours are already in [0, 1]
    if (vt.types[c] == Scalar::kUint8)
      scale = 1.0f / 255.0f;
    else if (vt.types[c] == Scalar::kUint16)
      scale = 1.0f / 65535.0f;
    else if (vt.types[c] != Scalar::kFloat32 && vt.types[c] != Scalar::kFloat64)
      fail("{}: PLY colour '{}' must be uchar, ushort, float or double", name, channels[k]);
    for (std::size_t i = 0; i < table.count; ++i) {
      const float v = table.columns[c][i];
      if (!std::isfinite(v))
        fail("{}: non-finite colour '{}' {} at vertex {}", name, channels[k], v, i);
      points.rgb[3 * i + k] = v * scale;
    }
  }
  return points;
}

void write_points_ply(const fs::path& path, const PointCloud& points) {
  if (points.xyz.size() % 3 != 0 || (!points.rgb.empty() && points.rgb.size() != points.xyz.size()))
    fail("{}: point cloud has {} xyz and {} rgb values", path.string(), points.xyz.size(),
         points.rgb.size());
  PlyTable table;
  table.count = points.size();
  const char* axes[] = {"x", "y", "z"};
  const char* channels[] = {"red", "green", "blue"};
  for (int k = 0; k < 3; ++k) {
    table.names.push_back(axes[k]);
    table.columns.emplace_back(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) table.columns.back()[i] = points.xyz[3 * i + k];
  }
  for (int k = 0; k < 3 && !points.rgb.empty(); ++k) {
    table.names.push_back(channels[k]);
    table.columns.emplace_back(points.size());
    for (std::size_t i = 0; i < points.size(); ++i)
      table.columns.back()[i] = points.rgb[3 * i + k] * 255.0f;
  }
  write_ply(path, table);
}

}  // namespace retimegs::io
