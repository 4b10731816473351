// libFuzzer harness: NumPy .npy arrays (io::read_npy and the int32 conversion).
#include <cstddef>
#include <cstdint>

#include "fuzz_util.hpp"
#include "retimegs/io/npy.hpp"

namespace fuzz = retimegs::fuzz;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const auto path = fuzz::scratch() / "array.npy";
  fuzz::write_bytes(path, fuzz::as_text(data, size));
  fuzz::refuse_with_error([&] { retimegs::io::read_npy(path).to_int(); });
  return 0;
}
