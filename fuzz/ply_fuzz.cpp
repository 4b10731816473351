// libFuzzer harness: points PLY files (io::read_points_ply: ASCII and binary headers and bodies).
#include <cstddef>
#include <cstdint>

#include "fuzz_util.hpp"
#include "retimegs/io/ply.hpp"

namespace fuzz = retimegs::fuzz;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const auto path = fuzz::scratch() / "points.ply";
  fuzz::write_bytes(path, fuzz::as_text(data, size));
  fuzz::refuse_with_error([&] { retimegs::io::read_points_ply(path); });
  return 0;
}
