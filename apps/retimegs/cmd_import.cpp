// retimegs import FORMAT --in SRC --out SCENE [--frames A:B] [--downscale F]
#include <memory>

#include "cli_util.hpp"
#include "commands.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/ingest/import.hpp"

namespace retimegs::app {

void add_import_command(CLI::App& app) {
  struct Args {
    std::string in, out, frames;
    double downscale = 1.0;
    int threads = 0;
    bool force = false;
  };
  using Importer = void (*)(const std::filesystem::path&, const std::filesystem::path&,
                            const ingest::ImportOptions&);
  struct Format {
    const char* name;
    const char* description;
    Importer run;
  };
  static const Format kFormats[] = {
      {"panoptic",
       "CMU Panoptic in the Dynamic3DGaussians layout: train_meta.json / test_meta.json, ims/, "
       "seg/ (masks); the test_meta cameras become test cameras.",
       ingest::import_panoptic},
      {"n3dv",
       "Neural3DV / DyNeRF: poses_bounds.npy and cam00.mp4, cam01.mp4, ...; cam00 becomes the "
       "test camera.",
       ingest::import_n3dv},
      {"colmap",
       "A COLMAP sparse model (SRC, SRC/sparse/0 or SRC/sparse; .bin or .txt) with SRC/images: one "
       "static frame, undistorted to pinhole.",
       ingest::import_colmap},
      {"nerfstudio",
       "A nerfstudio transforms.json (SRC or the file itself), with optional per-frame time and "
       "camera.",
       ingest::import_nerfstudio},
  };
  CLI::App* cmd = app.add_subcommand(
      "import", "Convert a public dataset layout into the scene format (DESIGN.md §4).");
  cmd->require_subcommand(1);
  for (const Format& format : kFormats) {
    auto args = std::make_shared<Args>();
    CLI::App* sub = cmd->add_subcommand(format.name, format.description);
    sub->add_option("--in", args->in, "source folder")->required();
    sub->add_option("--out", args->out, "scene folder to write (must not exist unless --force)")
        ->required();
    sub->add_option("--frames", args->frames,
                    "inclusive frame range A:B of the source (default: all)");
    sub->add_option("--downscale", args->downscale,
                    "divide the image size by F (intrinsics follow)")
        ->capture_default_str();
    sub->add_option("--threads", args->threads, "worker threads (0 = all cores)")
        ->capture_default_str();
    sub->add_flag("--force", args->force, "replace an existing output folder");
    sub->callback([args, run = format.run] {
      set_threads(args->threads);
      ingest::ImportOptions options;
      if (!args->frames.empty())
        std::tie(options.first_frame, options.last_frame) = parse_range(args->frames, "--frames");
      options.downscale = args->downscale;
      options.force = args->force;
      run(args->in, args->out, options);
    });
  }
}

}  // namespace retimegs::app
