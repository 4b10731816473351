// retimegs: continuous-time 4D Gaussian Splatting (RetimeGS) on the CPU.
#include <cstdio>
#include <exception>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/memory.hpp"

int main(int argc, char** argv) {
  CLI::App app{
      "retimegs: reconstruct a dynamic scene from calibrated multi-view video and render it at "
      "any real-valued time (slow motion, speed ramps, bullet time)."};
  app.require_subcommand(1);
  app.set_version_flag("--version", "retimegs 0.1.0");
  spdlog::set_pattern("[%H:%M:%S] %v");
  retimegs::keep_freed_memory();  // training renders allocate ~100 MB per step

  retimegs::app::add_synth_command(app);
  retimegs::app::add_import_command(app);
  retimegs::app::add_prepare_command(app);
  retimegs::app::add_train_command(app);
  retimegs::app::add_render_command(app);
  retimegs::app::add_eval_command(app);
  retimegs::app::add_export_command(app);
  retimegs::app::add_sheet_command(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; usage errors exit 2 with CLI11's one-line message.
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "retimegs: %s\n", e.what());
    return 2;
  } catch (const retimegs::Error& e) {
    std::fprintf(stderr, "retimegs: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "retimegs: unexpected error: %s\n", e.what());
    return 2;
  }
  return 0;
}
