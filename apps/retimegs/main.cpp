// retimegs: continuous-time 4D Gaussian Splatting (RetimeGS) on the CPU.
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/escape_control_chars.hpp"
#include "retimegs/core/interrupt.hpp"
#include "retimegs/core/memory.hpp"
#include "retimegs/media/image_io.hpp"

namespace {

// libgomp spins 300 000 times at a barrier before its threads sleep. On a machine busy with other
// work a spinning thread holds the core its partner needs, and a training step (hundreds of short
// parallel regions) runs several times slower; a short spin costs nothing measurable on an idle
// machine (bench/README.md, "train_bench"). libgomp reads the setting once, when it loads, so the
// program runs itself again with a short spin unless the user chose a wait policy.
void use_short_openmp_spin(char** argv) {
  if (std::getenv("GOMP_SPINCOUNT") || std::getenv("OMP_WAIT_POLICY")) return;
  setenv("GOMP_SPINCOUNT", RETIMEGS_GOMP_SPINCOUNT, 1);
  execv("/proc/self/exe", argv);  // returns only on failure: then run with libgomp's default
}

// CLI11 reports a missing or misspelt sub-command ("retimegs import foo") only as "A subcommand
// is required"; this names the command, the word it did not know and the choices.
std::string subcommand_message(CLI::App& app) {
  CLI::App* at = &app;
  std::string path = "retimegs";
  while (!at->get_subcommands().empty()) {
    at = at->get_subcommands().front();
    path += " " + at->get_name();
  }
  std::string choices;
  for (const CLI::App* sub : at->get_subcommands([](CLI::App*) { return true; }))
    choices += (choices.empty() ? "" : ", ") + sub->get_name();
  const std::vector<std::string> extra = at->remaining();
  if (!extra.empty() && extra.front().rfind("-", 0) != 0)
    return path + ": unknown command '" + extra.front() + "' (one of: " + choices + ")";
  return path + ": give one of: " + choices;
}

}  // namespace

int main(int argc, char** argv) {
  use_short_openmp_spin(argv);
  CLI::App app{
      "retimegs: reconstruct a dynamic scene from calibrated multi-view video and render it at "
      "any real-valued time (slow motion, speed ramps, bullet time)."};
  app.require_subcommand(1);
  app.set_version_flag("--version", "retimegs 0.1.0");
  spdlog::set_pattern("[%H:%M:%S] %v");
  retimegs::keep_freed_memory();  // training renders allocate ~100 MB per step
  retimegs::install_interrupt_handlers();
  retimegs::media::quiet_opencv_log();

  retimegs::app::add_synth_command(app);
  retimegs::app::add_import_command(app);
  retimegs::app::add_prepare_command(app);
  retimegs::app::add_train_command(app);
#ifndef RETIMEGS_LEAN_APP  // the lean GPU build's app has no frame writer and no viewer
  retimegs::app::add_render_command(app);
#endif
  retimegs::app::add_eval_command(app);
#ifndef RETIMEGS_LEAN_APP
  retimegs::app::add_export_command(app);
#endif
  retimegs::app::add_sheet_command(app);
  retimegs::app::add_merge_command(app);
  retimegs::app::add_slurm_command(app);
#ifndef RETIMEGS_LEAN_APP
  retimegs::app::add_view_command(app);
#endif

  try {
    app.parse(argc, argv);
  } catch (const CLI::RequiredError& e) {
    const bool subcommand = std::string(e.what()).find("subcommand") != std::string::npos;
    std::fprintf(stderr, "%s\n",
                 retimegs::escape_control_chars(subcommand ? subcommand_message(app)
                                                           : "retimegs: " + std::string(e.what()))
                     .c_str());
    return 2;
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; usage errors exit 2 with CLI11's one-line message.
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "retimegs: %s\n", retimegs::escape_control_chars(e.what()).c_str());
    return 2;
  } catch (const retimegs::Error& e) {
    std::fprintf(stderr, "retimegs: %s\n", retimegs::escape_control_chars(e.what()).c_str());
    return 2;
  } catch (const retimegs::Interrupted& e) {  // Ctrl-C / SIGTERM: 130 / 143
    std::fprintf(stderr, "retimegs: %s\n", retimegs::escape_control_chars(e.what()).c_str());
    return e.exit_code();
  } catch (const std::filesystem::filesystem_error& e) {
    // A path the system refused outside the checks that name it (too long a name, a loop of
    // links, no permission): the path and the reason, as an Error would give them.
    const std::string where = e.path1().empty() ? "" : e.path1().string() + ": ";
    std::fprintf(stderr, "retimegs: %s\n",
                 retimegs::escape_control_chars(where + e.code().message()).c_str());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "retimegs: unexpected error: %s\n",
                 retimegs::escape_control_chars(e.what()).c_str());
    return 2;
  }
  return 0;
}
