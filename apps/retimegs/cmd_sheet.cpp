// retimegs sheet --scene SCENE --out SHEET.png [--cameras LIST] [--frames LIST] [--stride K]
//                [--renders DIRS]
#include <filesystem>
#include <memory>

#include <spdlog/spdlog.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/eval/contact_sheet.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"

namespace retimegs::app {
namespace fs = std::filesystem;

void add_sheet_command(CLI::App& app) {
  struct Args {
    std::string scene, out, cameras, frames, renders;
    int tile_width = 256, stride = 0;
    bool force = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "sheet",
      "Write a contact sheet PNG of a scene: a row per camera with frames, mask and flow.");
  cmd->add_option("--scene", args->scene, "scene folder")->required();
  cmd->add_option("--out", args->out, "PNG file to write")->required();
  cmd->add_option("--cameras", args->cameras, "camera names, comma-separated (default: up to 4)");
  cmd->add_option("--frames", args->frames,
                  "frame numbers, comma-separated (default: first, middle, last)");
  cmd->add_option("--stride", args->stride,
                  "the flow column shows the first frame's flow K frames on (default: 2, the "
                  "stride train reads with --train-frames even, where it exists, else the "
                  "shortest that does)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--renders", args->renders,
                  "render folders (eval --save-renders), comma-separated: each frame's ground "
                  "truth is followed by DIR/<camera>/<frame:05d>.png of each");
  cmd->add_option("--tile-width", args->tile_width, "width of each tile in pixels")
      ->capture_default_str();
  cmd->add_flag("--force", args->force, "replace an existing output");
  cmd->callback([args] {
    std::vector<InputPath> inputs = scene_inputs(args->scene);
    if (!args->renders.empty())
      for (const auto& dir : split_list(args->renders, "--renders"))
        inputs.push_back({dir, "render folder", true});
    check_output_overlap(args->out, "--out", inputs);
    check_output_free(args->out, args->force);
    if (fs::path(args->out).extension() != ".png")
      fail("--out {}: the contact sheet is a PNG image; give a file name ending in .png",
           args->out);
    const io::Scene scene = media::read_scene(args->scene, media::SceneCheck::kJson);
    eval::SheetOptions options;
    options.tile_width = args->tile_width;
    options.flow_stride = args->stride;
    if (!args->cameras.empty())
      for (const auto& name : split_list(args->cameras, "--cameras"))
        options.cameras.push_back(scene.camera_index(name));
    if (!args->renders.empty())
      for (const auto& dir : split_list(args->renders, "--renders")) options.renders.push_back(dir);
    if (!args->frames.empty()) options.frames = parse_int_list(args->frames, "--frames");
    media::write_png(args->out, eval::contact_sheet(scene, options), 8, /*replace=*/args->force);
    spdlog::info("contact sheet: {}", args->out);
  });
}

}  // namespace retimegs::app
