// libFuzzer harness: Middlebury .flo optical flow files (io::read_flo).
#include <cstddef>
#include <cstdint>

#include "fuzz_util.hpp"
#include "retimegs/io/flow_io.hpp"

namespace fuzz = retimegs::fuzz;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const auto path = fuzz::scratch() / "flow.flo";
  fuzz::write_bytes(path, fuzz::as_text(data, size));
  fuzz::refuse_with_error([&] { retimegs::io::read_flo(path); });
  return 0;
}
