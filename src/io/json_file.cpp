#include "retimegs/io/json_file.hpp"

#include <fstream>

#include "retimegs/core/error.hpp"
#include "retimegs/core/input_file.hpp"

namespace retimegs::io {

namespace fs = std::filesystem;

nlohmann::json read_json_file(const std::filesystem::path& path, const std::string& what) {
  // A FIFO or a device would block or never end: only regular files are read.
  check_input_file(path, what);
  std::ifstream in(path);
  if (!in) fail("{}: cannot open {}", path.string(), what);
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    fail("{}: malformed JSON: {}", path.string(), e.what());
  }
}

}  // namespace retimegs::io
