// libFuzzer harness: render --retime CSV files (media::read_retime_csv) and the times their
// keyframes give (playback::ramp_times).
#include <cstddef>
#include <cstdint>

#include "fuzz_util.hpp"
#include "retimegs/media/frame_writer.hpp"
#include "retimegs/playback/times.hpp"

namespace fuzz = retimegs::fuzz;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const auto path = fuzz::scratch() / "retime.csv";
  fuzz::write_bytes(path, fuzz::as_text(data, size));
  fuzz::refuse_with_error(
      [&] { retimegs::playback::ramp_times(retimegs::media::read_retime_csv(path)); });
  return 0;
}
