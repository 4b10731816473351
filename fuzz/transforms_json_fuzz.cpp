// libFuzzer harness: nerfstudio / instant-ngp transforms.json (ingest::import_nerfstudio). The
// source folder holds the fuzzed transforms.json and two 4x3 images, a.png (RGB) and b.png (RGBA),
// that its file_path / mask_path entries may name; a scene imported from it goes to the scratch
// area.
#include <cstddef>
#include <cstdint>

#include "fuzz_util.hpp"
#include "retimegs/ingest/import.hpp"
#include "retimegs/media/image_io.hpp"

namespace fuzz = retimegs::fuzz;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const auto source = [] {
    const auto dir = fuzz::fresh_folder("nerfstudio");
    retimegs::media::write_png(dir / "a.png", retimegs::Image(4, 3, 3, 0.5f));
    retimegs::media::write_png(dir / "b.png", retimegs::Image(4, 3, 4, 0.75f));
    return dir;
  }();
  static const auto out = fuzz::scratch() / "nerfstudio_scene";
  fuzz::write_bytes(source / "transforms.json", fuzz::as_text(data, size));
  retimegs::ingest::ImportOptions options;
  options.force = true;
  options.progress = false;
  fuzz::refuse_with_error([&] { retimegs::ingest::import_nerfstudio(source, out, options); });
  return 0;
}
