// libFuzzer harness: Panoptic metadata in the Dynamic3DGaussians layout (ingest::import_panoptic).
// The input holds train_meta.json and test_meta.json separated by fuzz::kFileSeparator (an empty
// second part: no test_meta.json); the source folder has 4x3 images ims/0/000000.png and
// ims/1/000000.png with a mask seg/0/000000.png that the metadata's 'fn' entries may name.
#include <cstddef>
#include <cstdint>
#include <filesystem>

#include "fuzz_util.hpp"
#include "retimegs/ingest/import.hpp"
#include "retimegs/media/image_io.hpp"

namespace fuzz = retimegs::fuzz;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const auto source = [] {
    const auto dir = fuzz::fresh_folder("panoptic");
    for (const char* camera : {"0", "1"}) {
      std::filesystem::create_directories(dir / "ims" / camera);
      retimegs::media::write_png(dir / "ims" / camera / "000000.png",
                                 retimegs::Image(4, 3, 3, 0.5f));
    }
    std::filesystem::create_directories(dir / "seg" / "0");
    retimegs::media::write_png(dir / "seg" / "0" / "000000.png", retimegs::Image(4, 3, 1, 1.0f));
    return dir;
  }();
  static const auto out = fuzz::scratch() / "panoptic_scene";
  const auto files = fuzz::split_files(data, size, 2);
  fuzz::write_bytes(source / "train_meta.json", files[0]);
  std::filesystem::remove(source / "test_meta.json");
  if (!files[1].empty()) fuzz::write_bytes(source / "test_meta.json", files[1]);
  retimegs::ingest::ImportOptions options;
  options.force = true;
  options.progress = false;
  fuzz::refuse_with_error([&] { retimegs::ingest::import_panoptic(source, out, options); });
  return 0;
}
