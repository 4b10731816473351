// libFuzzer harness: 3DGS splat PLY files (io::read_splat_ply, Inria layout).
#include <cstddef>
#include <cstdint>

#include "fuzz_util.hpp"
#include "retimegs/io/splat_ply.hpp"

namespace fuzz = retimegs::fuzz;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const auto path = fuzz::scratch() / "splats.ply";
  fuzz::write_bytes(path, fuzz::as_text(data, size));
  fuzz::refuse_with_error([&] { retimegs::io::read_splat_ply(path); });
  return 0;
}
