#include "retimegs/core/executable.hpp"

#include <unistd.h>

#include <cstdlib>

namespace retimegs {
namespace fs = std::filesystem;

fs::path find_executable(const std::string& name) {
  auto runnable = [](const fs::path& p) {
    std::error_code ec;  // an unreadable PATH folder is skipped, as a shell skips it
    return fs::is_regular_file(p, ec) && ::access(p.c_str(), X_OK) == 0;
  };
  if (name.find('/') != std::string::npos) return runnable(name) ? fs::path(name) : fs::path();
  const char* path = std::getenv("PATH");
  const std::string dirs = path ? path : "/usr/local/bin:/usr/bin:/bin";
  for (std::size_t start = 0; start <= dirs.size();) {
    std::size_t end = dirs.find(':', start);
    if (end == std::string::npos) end = dirs.size();
    const fs::path candidate = fs::path(dirs.substr(start, end - start)) / name;
    if (end > start && runnable(candidate)) return candidate;
    start = end + 1;
  }
  return {};
}

}  // namespace retimegs
