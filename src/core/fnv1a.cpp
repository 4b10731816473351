#include "retimegs/core/fnv1a.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <vector>

#include "retimegs/core/error.hpp"
#include "retimegs/core/input_file.hpp"

namespace retimegs {

std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t hash) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < size; ++i) {
    hash ^= bytes[i];
    hash *= 0x100000001b3ull;  // FNV prime
  }
  return hash;
}

std::uint64_t fnv1a64_file(const std::filesystem::path& file) {
  check_input_file(file, "a file to hash");
  std::ifstream in(file, std::ios::binary);
  if (!in) fail("{}: cannot open: {}", file.string(), std::strerror(errno));
  std::vector<char> chunk(std::size_t(1) << 20);
  std::uint64_t hash = kFnv1a64Basis;
  while (in) {
    in.read(chunk.data(), std::streamsize(chunk.size()));
    hash = fnv1a64(chunk.data(), std::size_t(in.gcount()), hash);
  }
  if (!in.eof()) fail("{}: read failed: {}", file.string(), std::strerror(errno));
  return hash;
}

}  // namespace retimegs
