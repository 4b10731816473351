// libFuzzer harness: the rig calibration files of `import videos --calib` (OpenCV FileStorage,
// YAML or JSON; ingest::detail::read_rig_text). An input whose first non-blank byte is '{' is
// read as a .json rig, any other as a .yaml one.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "calibration.hpp"
#include "fuzz_util.hpp"

namespace fuzz = retimegs::fuzz;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text = fuzz::as_text(data, size);
  const std::size_t first = text.find_first_not_of(" \t\r\n");
  const bool json = first != std::string_view::npos && text[first] == '{';
  fuzz::refuse_with_error(
      [&] { retimegs::ingest::detail::read_rig_text(text, json, json ? "rig.json" : "rig.yaml"); });
  return 0;
}
