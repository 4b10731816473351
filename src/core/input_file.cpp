#include "retimegs/core/input_file.hpp"

#include <fstream>

#include "retimegs/core/error.hpp"
#include "retimegs/core/interrupt.hpp"

namespace retimegs {
namespace fs = std::filesystem;

namespace {
const char* kind_of(const fs::file_status& status) {
  switch (status.type()) {
    case fs::file_type::directory:
      return "a folder";
    case fs::file_type::fifo:
      return "a FIFO";
    case fs::file_type::socket:
      return "a socket";
    case fs::file_type::character:
    case fs::file_type::block:
      return "a device";
    default:
      return "not a regular file";
  }
}
}  // namespace

void check_input_file(const fs::path& path, const std::string& what) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec || !fs::exists(status) || fs::is_regular_file(status)) return;
  fail("{}: is {}, not a regular file (cannot read {} from it)", path.string(), kind_of(status),
       what);
}

fs::file_status input_status(const fs::path& path) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec && status.type() != fs::file_type::not_found)
    fail("{}: cannot look it up ({})", path.string(), ec.message());
  return status;
}

std::string read_text_file(const fs::path& path, const std::string& what) {
  check_input_file(path, what);
  std::ifstream in(path, std::ios::binary);
  if (!in) fail("{}: cannot open {}", path.string(), what);
  // In blocks of 1 MiB, polling for Ctrl-C between them: a model file can be gigabytes.
  std::string text, block(std::size_t(1) << 20, '\0');
  std::error_code ec;
  if (const auto size = fs::file_size(path, ec); !ec) text.reserve(size);
  while (in.read(block.data(), std::streamsize(block.size())) || in.gcount() > 0) {
    text.append(block.data(), std::size_t(in.gcount()));
    throw_if_interrupted();
  }
  if (in.bad()) fail("{}: cannot read {}", path.string(), what);
  return text;
}

}  // namespace retimegs
