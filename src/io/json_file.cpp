#include "retimegs/io/json_file.hpp"

#include <fstream>

#include "retimegs/core/error.hpp"

namespace retimegs::io {

nlohmann::json read_json_file(const std::filesystem::path& path, const std::string& what) {
  std::ifstream in(path);
  if (!in) fail("{}: cannot open {}", path.string(), what);
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    fail("{}: malformed JSON: {}", path.string(), e.what());
  }
}

}  // namespace retimegs::io
