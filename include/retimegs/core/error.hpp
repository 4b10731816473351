#pragma once
// The one exception type of the project. Its message names the file, field or value at fault,
// so that apps can print it as a single line and exit with status 2.
#include <stdexcept>
#include <string>

#include <fmt/format.h>

namespace retimegs {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

// throw Error(fmt::format(...)) in one call.
template <typename... Args>
[[noreturn]] void fail(fmt::format_string<Args...> format, Args&&... args) {
  throw Error(fmt::format(format, std::forward<Args>(args)...));
}

}  // namespace retimegs
