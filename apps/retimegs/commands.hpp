#pragma once
// Each sub-command registers its flags and a callback that calls the library. Apps only parse
// arguments; all work happens in the libraries.
#include <CLI/CLI.hpp>

namespace retimegs::app {

void add_synth_command(CLI::App& app);
void add_import_command(CLI::App& app);
void add_prepare_command(CLI::App& app);
void add_sheet_command(CLI::App& app);
void add_render_command(CLI::App& app);
void add_export_command(CLI::App& app);
void add_train_command(CLI::App& app);
void add_eval_command(CLI::App& app);
void add_merge_command(CLI::App& app);
void add_slurm_command(CLI::App& app);
void add_view_command(CLI::App& app);

}  // namespace retimegs::app
