#pragma once
// The one exception type of the project. Its message names the file, field or value at fault,
// so that apps can print it as a single line and exit with status 2.
//
// The message is stored with its control bytes escaped (core/escape_control_chars.hpp): user text
// it quotes (a name read from a file, a path) may hold a newline, which would break the one line,
// or a NUL, where what()'s C string would end and cut the message short.
#include <stdexcept>
#include <string>

#include <fmt/format.h>

#include "retimegs/core/escape_control_chars.hpp"

namespace retimegs {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(escape_control_chars(message)) {}
};

// throw Error(fmt::format(...)) in one call.
template <typename... Args>
[[noreturn]] void fail(fmt::format_string<Args...> format, Args&&... args) {
  throw Error(fmt::format(format, std::forward<Args>(args)...));
}

}  // namespace retimegs
