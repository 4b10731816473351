// retimegs view --model MODEL [--scene SCENE] [--near D] [--port 7007] [--host 127.0.0.1]
#include <cstdio>
#include <memory>
#include <optional>

#include "cli_util.hpp"
#include "commands.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/model/model_file.hpp"
#include "retimegs/model/window.hpp"
#include "retimegs/view/web.hpp"
#include "web_pack.hpp"

namespace retimegs::app {

view::Packed pack_for_web(const std::string& model_path, const std::string& scene_path,
                          const std::optional<double>& near) {
  // A window model is drawn over its own frames, as render draws it (model/window.hpp).
  const model::Model model = model::window_view(model::read_model(model_path));
  std::optional<io::Scene> scene;
  view::PackScene pack_scene;
  if (!scene_path.empty()) {
    scene = io::read_scene(scene_path, io::SceneCheck::kJson);
    pack_scene.scene = &*scene;
    pack_scene.near_plane = near_plane(near, *scene);
  } else if (near) {
    io::Scene none;
    pack_scene.near_plane = near_plane(near, none);
  }
  return view::pack(model, pack_scene);
}

void add_view_command(CLI::App& app) {
  struct Args {
    std::string model, scene, host = "127.0.0.1";
    int port = 7007;
    std::optional<double> near;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "view",
      "Serve the browser viewer for a 4D model: play, scrub and slow down time, orbit or fly, "
      "snap to the scene's cameras. Prints the URL and serves until Ctrl-C.");
  cmd->add_option("--model", args->model, "4D model (.rgs)")
      ->required()
      ->check(input_file("a model"));
  cmd->add_option("--scene", args->scene,
                  "scene folder: its cameras (snap to them, camera=NAME links), up vector and "
                  "near plane");
  add_near_option(*cmd, args->near);
  cmd->add_option("--port", args->port, "TCP port (0: any free port)")
      ->check(CLI::Range(0, 65535))
      ->capture_default_str();
  cmd->add_option("--host", args->host,
                  "address to listen on (0.0.0.0 shows the model to the network)")
      ->capture_default_str();
  cmd->callback([args] {
    // The model is read and packed before the port is bound: a bad model is refused at once.
    const view::Packed packed = pack_for_web(args->model, args->scene, args->near);
    view::serve(view::web_files(packed), args->host, args->port, [](const std::string& url) {
      std::printf("retimegs view: serving %s (Ctrl-C to stop)\n", url.c_str());
      std::fflush(stdout);
    });
  });
}

}  // namespace retimegs::app
