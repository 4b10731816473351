// libFuzzer harness: scene.json (io::read_scene_json: the JSON checks, no images).
#include <cstddef>
#include <cstdint>

#include "fuzz_util.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/scene_images.hpp"

namespace fuzz = retimegs::fuzz;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const auto dir = fuzz::fresh_folder("scene");
  fuzz::write_bytes(dir / "scene.json", fuzz::as_text(data, size));
  fuzz::refuse_with_error([&] { retimegs::io::read_scene_json(dir); });
  return 0;
}
