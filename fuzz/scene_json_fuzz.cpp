// libFuzzer harness: scene.json (io::read_scene, the JSON checks only: no images).
#include <cstddef>
#include <cstdint>

#include "fuzz_util.hpp"
#include "retimegs/io/scene.hpp"

namespace fuzz = retimegs::fuzz;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const auto dir = fuzz::fresh_folder("scene");
  fuzz::write_bytes(dir / "scene.json", fuzz::as_text(data, size));
  fuzz::refuse_with_error([&] { retimegs::io::read_scene(dir, retimegs::io::SceneCheck::kJson); });
  return 0;
}
