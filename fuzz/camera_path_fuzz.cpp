// libFuzzer harness: nerfstudio camera_path.json (io::read_camera_path_json).
#include <cstddef>
#include <cstdint>

#include "fuzz_util.hpp"
#include "retimegs/io/camera_path_json.hpp"

namespace fuzz = retimegs::fuzz;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const auto path = fuzz::scratch() / "camera_path.json";
  fuzz::write_bytes(path, fuzz::as_text(data, size));
  fuzz::refuse_with_error([&] {
    const auto file = retimegs::io::read_camera_path_json(path);
    if (file.timed) retimegs::io::camera_path_times(file, 0.0, 1.0);
  });
  return 0;
}
