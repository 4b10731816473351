// libFuzzer harness: .rgs model files (model::read_model).
//
// The file ends with an FNV-1a 64 checksum of everything before it; the harness rewrites it so
// that mutated inputs reach the header and field checks instead of stopping at the checksum.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "fuzz_util.hpp"
#include "retimegs/model/model_file.hpp"

namespace fuzz = retimegs::fuzz;

namespace {
std::uint64_t fnv1a64(const char* data, std::size_t size) {
  std::uint64_t hash = 0xcbf29ce484222325ull;
  for (std::size_t i = 0; i < size; ++i) {
    hash ^= static_cast<unsigned char>(data[i]);
    hash *= 0x100000001b3ull;
  }
  return hash;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const auto path = fuzz::scratch() / "model.rgs";
  std::string bytes(reinterpret_cast<const char*>(data), size);
  if (bytes.size() >= sizeof(std::uint64_t)) {
    const std::size_t body = bytes.size() - sizeof(std::uint64_t);
    const std::uint64_t sum = fnv1a64(bytes.data(), body);
    std::memcpy(bytes.data() + body, &sum, sizeof sum);
  }
  fuzz::write_bytes(path, bytes);
  fuzz::refuse_with_error([&] { retimegs::model::read_model(path); });
  return 0;
}
