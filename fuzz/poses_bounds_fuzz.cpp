// libFuzzer harness: Neural3DV poses_bounds.npy (ingest::import_n3dv). The source folder holds the
// fuzzed poses_bounds.npy and no video: every pose row is checked before the videos are looked
// for, so the harness covers the whole metadata parser without decoding video.
#include <cstddef>
#include <cstdint>

#include "fuzz_util.hpp"
#include "retimegs/ingest/import.hpp"

namespace fuzz = retimegs::fuzz;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const auto source = fuzz::fresh_folder("n3dv");
  static const auto out = fuzz::scratch() / "n3dv_scene";
  fuzz::write_bytes(source / "poses_bounds.npy", fuzz::as_text(data, size));
  retimegs::ingest::ImportOptions options;
  options.force = true;
  options.progress = false;
  fuzz::refuse_with_error([&] { retimegs::ingest::import_n3dv(source, out, options); });
  return 0;
}
