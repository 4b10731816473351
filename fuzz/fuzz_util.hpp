#pragma once
// Shared pieces of the libFuzzer harnesses (fuzz/<target>_fuzz.cpp).
//
// A harness feeds the fuzzer's bytes to one parser and accepts exactly one outcome besides
// success: retimegs::Error (the project's one-line, culprit-naming failure). Any other exception
// escapes and aborts, so libFuzzer reports it beside crashes, leaks, undefined behaviour,
// timeouts and allocations above -rss_limit_mb / -malloc_limit_mb.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "retimegs/core/error.hpp"

namespace retimegs::fuzz {

// A scratch folder of this process in memory-backed /dev/shm (else the system temporary folder):
// parsers that take a path read the fuzzer's bytes from a file there. Removed at exit.
inline const std::filesystem::path& scratch() {
  static const std::filesystem::path dir = [] {
    namespace fs = std::filesystem;
    const fs::path base =
        fs::is_directory("/dev/shm") ? fs::path("/dev/shm") : fs::temp_directory_path();
    const fs::path d = base / ("retimegs-fuzz-" + std::to_string(::getpid()));
    fs::remove_all(d);
    fs::create_directories(d);
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(scratch(), ec);
    });
    return d;
  }();
  return dir;
}

// Writes `bytes` to `path` (its folder created), replacing what was there.
inline void write_bytes(const std::filesystem::path& path, std::string_view bytes) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), std::streamsize(bytes.size()));
  if (!out) std::abort();  // the scratch folder itself failed: not a finding of the parser
}

// Empties a folder of the scratch area (created if needed) and returns it.
inline std::filesystem::path fresh_folder(const std::string& name) {
  const std::filesystem::path d = scratch() / name;
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

// The separator between the files of a multi-file input (COLMAP models, importers' folders).
constexpr std::string_view kFileSeparator = "\n--8<--\n";

// Splits the input at kFileSeparator into exactly `n` parts: missing ones are empty, the last one
// keeps any further separators.
inline std::vector<std::string_view> split_files(const std::uint8_t* data, std::size_t size,
                                                 std::size_t n) {
  std::string_view rest(reinterpret_cast<const char*>(data), size);
  std::vector<std::string_view> parts;
  while (parts.size() + 1 < n) {
    const std::size_t at = rest.find(kFileSeparator);
    if (at == std::string_view::npos) break;
    parts.push_back(rest.substr(0, at));
    rest.remove_prefix(at + kFileSeparator.size());
  }
  parts.push_back(rest);
  parts.resize(n);
  return parts;
}

inline std::string_view as_text(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

// Runs `parse`; retimegs::Error is the expected way to refuse an input.
template <typename F>
void refuse_with_error(F&& parse) {
  try {
    parse();
  } catch (const retimegs::Error&) {
  }
}

}  // namespace retimegs::fuzz
