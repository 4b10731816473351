// libFuzzer harness: COLMAP binary sparse models (io::read_colmap_model on cameras.bin, images.bin,
// points3D.bin: the input holds the three files, separated by fuzz::kFileSeparator).
#include <cstddef>
#include <cstdint>

#include "fuzz_util.hpp"
#include "retimegs/io/colmap.hpp"

namespace fuzz = retimegs::fuzz;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const auto dir = fuzz::fresh_folder("colmap_bin");
  const auto files = fuzz::split_files(data, size, 3);
  fuzz::write_bytes(dir / "cameras.bin", files[0]);
  fuzz::write_bytes(dir / "images.bin", files[1]);
  fuzz::write_bytes(dir / "points3D.bin", files[2]);
  fuzz::refuse_with_error([&] { retimegs::io::read_colmap_model(dir).point_cloud(); });
  return 0;
}
