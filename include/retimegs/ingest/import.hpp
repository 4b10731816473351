#pragma once
// Importers from public dataset layouts into the scene format (DESIGN.md §1 `retimegs import`).
#include <filesystem>

namespace retimegs::ingest {

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

// Neural3DV / DyNeRF: poses_bounds.npy ([N, 17] float64: the 3x5 LLFF matrix [R | t | (h, w, f)]
// row-major, columns (down, right, back) camera-to-world, then near and far) and one video per
// camera, cam00.mp4, cam01.mp4, ... (sorted by name, one per row), decoded with OpenCV's FFmpeg
// backend. Cameras are named after the videos ("cam00", ...), the principal point is the image
// centre, fps is the first video's. DyNeRF holds cam00 out: it gets split "test" (when there is
// more than one camera). The intrinsics follow the video size when it differs from (w, h).
void import_n3dv(const std::filesystem::path& source, const std::filesystem::path& out,
                 const ImportOptions& options);

// COLMAP project: a sparse model (source itself, source/sparse/0 or source/sparse; .bin or .txt)
// and its images in source/images (or beside the model: ../images, ../../images). A static
// capture: one scene frame at 30 fps; cameras are named after the image file names without
// extension (folders joined with '_' where the stems alone collide). Distorted camera models
// are resampled into pinhole cameras of the same size (import_common.hpp: Undistorter); the
// model's points become points/00000.ply.
void import_colmap(const std::filesystem::path& source, const std::filesystem::path& out,
                   const ImportOptions& options);

// nerfstudio / instant-ngp transforms.json (see import_nerfstudio.cpp for the grouping rule of
// frames into scene frames and cameras).
void import_nerfstudio(const std::filesystem::path& source, const std::filesystem::path& out,
                       const ImportOptions& options);

}  // namespace retimegs::ingest
