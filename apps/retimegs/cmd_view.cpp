// retimegs view --model MODEL [--scene SCENE] [--near D] [--port 7007] [--host 127.0.0.1]
#include <cstdio>
#include <memory>
#include <optional>

#include "cli_util.hpp"
#include "commands.hpp"
#include "retimegs/view/pack.hpp"
#include "retimegs/view/web.hpp"

namespace retimegs::app {

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
      ->capture_default_str()
      ->check(CLI::Validator(
          [](std::string& host) {
            return host.empty() ? std::string(
                                      "must name an address (127.0.0.1, or 0.0.0.0 for "
                                      "the network)")
                                : std::string();
          },
          "ADDRESS"));
  cmd->callback([args] {
    // The model is read and packed before the port is bound: a bad model is refused at once.
    const view::Packed packed = view::pack_for_web(args->model, args->scene, args->near);
    view::serve(view::web_files(packed), args->host, args->port, [](const std::string& url) {
      std::printf("retimegs view: serving %s (Ctrl-C to stop)\n", url.c_str());
      std::fflush(stdout);
    });
  });
}

}  // namespace retimegs::app
