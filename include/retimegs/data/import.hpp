#pragma once
// Importers from public dataset layouts into the scene format (DESIGN.md §1 `retimegs import`).
#include <filesystem>

namespace retimegs::data {

struct ImportOptions {
  int first_frame = 0;
  int last_frame = -1;     // inclusive; -1 = to the end of the source
  double downscale = 1.0;  // image size divided by this (intrinsics follow)
  bool force = false;      // replace an existing output folder
  bool progress = true;
};

// Dynamic3DGaussians layout of CMU Panoptic: train_meta.json / test_meta.json,
// ims/<cam>/<frame:06d>.jpg, seg/<cam>/<frame:06d>.png. Camera names are the Panoptic ids as
// decimal strings; cameras of test_meta.json get split "test". Masks are copied where present.
void import_panoptic(const std::filesystem::path& source, const std::filesystem::path& out,
                     const ImportOptions& options);

}  // namespace retimegs::data
