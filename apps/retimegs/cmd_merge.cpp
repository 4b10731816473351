// retimegs merge --out M.rgs [--force] RUN1/model.rgs RUN2/model.rgs ...
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "retimegs/core/atomic_file.hpp"
#include "retimegs/model/merge.hpp"
#include "retimegs/model/model_file.hpp"

namespace retimegs::app {

void add_merge_command(CLI::App& app) {
  struct Args {
    std::string out;
    std::vector<std::string> models;
    bool force = false;
    std::optional<double> seam_fade;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "merge",
      "Stitch window models of one clip (train --window), each starting at or before the frame "
      "where the previous one ends, into one model of the frames they cover together.");
  cmd->add_option("--out", args->out, "merged model file (.rgs)")->required();
  cmd->add_option("models", args->models, "window models (.rgs), in any order")
      ->required()
      ->expected(1, -1)
      ->check(input_file("a model"));
  cmd->add_option("--seam-fade", args->seam_fade,
                  "cross-fade at each seam: near one a frame fades from the window before it, "
                  "drawn whole, into the one after it over a sigmoid of this many training "
                  "intervals (0: gamma, a jump within a tenth of a frame)")
      ->default_str(fmt::format("{}", model::kDefaultSeamFade));
  cmd->add_flag("--force", args->force, "replace an existing --out");
  cmd->callback([args] {
    std::vector<InputPath> inputs;
    for (const std::string& path : args->models) inputs.push_back({path, "model"});
    check_output_overlap(args->out, "--out", inputs);
    model::check_model_file_name(args->out, "--out");
    check_output_free(args->out, args->force);
    std::vector<model::Model> windows;
    for (const std::string& path : args->models) windows.push_back(model::read_model(path));
    const model::Model merged = model::merge_models(windows, args->models, args->seam_fade);
    model::write_model(args->out, merged, /*replace=*/args->force);
    const model::TimeWindow span =
        merged.window.value_or(model::TimeWindow{0, merged.grid.count - 1});
    spdlog::info("merged {} window{} into {}: {} primitives, frames {}..{}", windows.size(),
                 windows.size() == 1 ? "" : "s", args->out, merged.primitives.size(),
                 merged.grid.at(span.first), merged.grid.at(span.last));
  });
}

}  // namespace retimegs::app
