// retimegs import FORMAT --in SRC --out SCENE [--frames A:B] [--downscale F]
#include <memory>

#include "cli_util.hpp"
#include "commands.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/ingest/import.hpp"

namespace retimegs::app {

void add_import_command(CLI::App& app) {
  struct Args {
    std::string format, in, out, frames;
    double downscale = 1.0;
    int threads = 0;
    bool force = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "import", "Convert a public dataset layout into the scene format (DESIGN.md §4).");
  cmd->add_option("format", args->format,
                  "source layout: panoptic (Dynamic3DGaussians train_meta.json/test_meta.json, "
                  "ims/, seg/), n3dv (Neural3DV/DyNeRF poses_bounds.npy + cam00.mp4 ...; cam00 "
                  "becomes the test camera), colmap (sparse model in SRC, SRC/sparse/0 or "
                  "SRC/sparse, .bin or .txt, + SRC/images; one static frame, undistorted to "
                  "pinhole), nerfstudio (transforms.json, optional per-frame time and camera)")
      ->required()
      ->check(CLI::IsMember({"panoptic", "n3dv", "colmap", "nerfstudio"}));
  cmd->add_option("--in", args->in, "source folder (nerfstudio: or its transforms.json)")
      ->required();
  cmd->add_option("--out", args->out, "scene folder to write (must not exist unless --force)")
      ->required();
  cmd->add_option("--frames", args->frames,
                  "inclusive frame range A:B of the source (default: all)");
  cmd->add_option("--downscale", args->downscale, "divide the image size by F (intrinsics follow)")
      ->capture_default_str();
  cmd->add_option("--threads", args->threads, "worker threads (0 = all cores)")
      ->capture_default_str();
  cmd->add_flag("--force", args->force, "replace an existing output folder");
  cmd->callback([args] {
    set_threads(args->threads);
    ingest::ImportOptions options;
    if (!args->frames.empty())
      std::tie(options.first_frame, options.last_frame) = parse_range(args->frames, "--frames");
    options.downscale = args->downscale;
    options.force = args->force;
    if (args->format == "panoptic") ingest::import_panoptic(args->in, args->out, options);
    if (args->format == "n3dv") ingest::import_n3dv(args->in, args->out, options);
    if (args->format == "colmap") ingest::import_colmap(args->in, args->out, options);
    if (args->format == "nerfstudio") ingest::import_nerfstudio(args->in, args->out, options);
  });
}

}  // namespace retimegs::app
