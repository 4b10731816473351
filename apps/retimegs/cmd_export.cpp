// retimegs export --model MODEL (--time T --out SPLAT.ply | --times A:B:STEP --out DIR)
// retimegs export --model MODEL --web DIR [--scene SCENE] [--near D]
#include <memory>
#include <optional>

#include <spdlog/spdlog.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/playback/export_times.hpp"
#include "retimegs/playback/render_model.hpp"
#include "retimegs/playback/times.hpp"
#include "retimegs/view/pack.hpp"
#include "retimegs/view/web.hpp"

namespace retimegs::app {

void add_export_command(CLI::App& app) {
  struct Args {
    std::string model, times, out, web, scene;
    std::optional<double> time, near;
    bool force = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "export",
      "Write the 3D Gaussians of a time as a standard 3DGS .ply (Inria layout) that SuperSplat and "
      "other splat viewers open; --times writes a sequence DIR/<k:05d>.ply with DIR/times.csv; "
      "--web DIR writes the browser viewer with the model as a static site.");
  cmd->add_option("--model", args->model, "4D model (.rgs)")
      ->required()
      ->check(input_file("a model"));
  auto* time = cmd->add_option("--time", args->time, "time in scene frame units");
  auto* times = cmd->add_option("--times", args->times, "times A:B:STEP (inclusive of B)");
  time->excludes(times);
  auto* out_option =
      cmd->add_option("--out", args->out, "SPLAT.ply for --time, a folder for --times");
  auto* web = cmd->add_option("--web", args->web,
                              "folder: the browser viewer (index.html, its scripts, model.json, "
                              "model.bin) for any static web host");
  web->excludes(time)->excludes(times)->excludes(out_option);
  cmd->add_option("--scene", args->scene,
                  "--web: scene folder whose cameras, up vector and near plane the viewer uses");
  add_near_option(*cmd, args->near);
  cmd->add_flag("--force", args->force, "replace an existing output");
  cmd->callback([args] {
    if (!args->web.empty()) {
      std::vector<InputPath> inputs = {{args->model, "model"}};
      if (!args->scene.empty()) inputs.push_back({args->scene, "scene"});
      // Nor may it replace the scene's own files (scene.json, images, ...), even with --force.
      for (const InputPath& in : scene_inputs(args->scene)) inputs.push_back(in);
      check_output_overlap(args->web, "--web", inputs);
      const view::Packed packed = view::pack_for_web(args->model, args->scene, args->near);
      view::write_web(args->web, view::web_files(packed), args->force);
      spdlog::info("wrote the viewer to {} ({:.1f} MB of model data)", args->web,
                   packed.data.size() / 1e6);
      return;
    }
    if (!args->scene.empty() || args->near) fail("export: --scene and --near go with --web");
    if (!args->time && args->times.empty()) fail("export: give --time, --times or --web");
    if (args->out.empty()) fail("export: --time and --times need --out");
    check_output_overlap(args->out, "--out", {{args->model, "model"}});
    const model::Model m = playback::read_4d_model(args->model);
    if (args->time) {
      const std::size_t n = playback::export_time(m, *args->time, args->out, args->force);
      spdlog::info("exported {} Gaussians at t = {} to {}", n, *args->time, args->out);
      return;
    }
    const std::vector<double> listed =
        playback::range_times(parse_time_range(args->times, "--times"), "--times");
    playback::export_times(m, listed, args->out, args->force);
    spdlog::info("exported {} times to {}", listed.size(), args->out);
  });
}

}  // namespace retimegs::app
