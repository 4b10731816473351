#include "retimegs/train/checkpoint.hpp"

#include <sstream>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/io/json_file.hpp"
#include "retimegs/io/npy.hpp"

namespace retimegs::train {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// Writes `adam`'s moments to dir/adam/<name>_{m,v}.npy and its step count to state.
void write_adam(const fs::path& dir, const std::string& name, const Adam& adam, json& state) {
  state["adam_steps"][name] = adam.steps();
  const std::size_t rows = adam.rows();
  const std::size_t width = rows ? adam.m().size() / rows : 0;
  io::write_npy(dir / "adam" / (name + "_m.npy"), {rows, width}, adam.m());
  io::write_npy(dir / "adam" / (name + "_v.npy"), {rows, width}, adam.v());
}

// The value at `key` ("rng", "adam_steps/mu") of a checkpoint's state.json `file` as a T; throws
// Error naming the file and the key when it is missing or of another type.
template <typename T>
T state_value(const json& state, const std::string& key, const fs::path& file) {
  const json::json_pointer pointer("/" + key);
  if (!state.contains(pointer)) fail("{}: checkpoint state lacks '{}'", file.string(), key);
  try {
    return state.at(pointer).get<T>();
  } catch (const json::exception&) {
    fail("{}: checkpoint state '{}' has the wrong type: {}", file.string(), key,
         state.at(pointer).dump());
  }
}

}  // namespace

void write_checkpoint(const fs::path& dir, const model::Model& model, int iteration,
                      const std::mt19937_64& rng, const NamedAdams& optimizers) {
  AtomicDirectory out(dir, /*replace=*/true);
  model::write_model(out.temp_path() / "model.rgs", model);
  std::ostringstream rng_text;
  rng_text << rng;
  json state = {
      {"iteration", iteration}, {"rng", rng_text.str()}, {"sh_degree", model.config.sh_degree}};
  for (const auto& [name, adam] : optimizers) write_adam(out.temp_path(), name, *adam, state);
  write_text_file(out.temp_path() / "state.json", state.dump(2) + "\n");
  out.commit();
}

Checkpoint::Checkpoint(const fs::path& dir, const model::TimeGrid& grid)
    : model(model::read_model(dir / "model.rgs")), dir_(dir), state_file_(dir / "state.json") {
  if (model.grid.first != grid.first || model.grid.step != grid.step ||
      model.grid.count != grid.count)
    fail(
        "{}: the checkpoint trained {} frames from frame {} (step {}), this run trains {} from "
        "frame {} (step {}): resume with the same --window and --train-frames",
        dir.string(), model.grid.count, model.grid.first, model.grid.step, grid.count, grid.first,
        grid.step);
  state_ = io::read_json_file(state_file_, "checkpoint state");
  iteration = state_value<int>(state_, "iteration", state_file_);
  if (!(std::istringstream(state_value<std::string>(state_, "rng", state_file_)) >> rng))
    fail("{}: checkpoint state 'rng' is not a generator state", state_file_.string());
  model.config.sh_degree = state_value<int>(state_, "sh_degree", state_file_);
}

void Checkpoint::read_adam(const std::string& name, Adam& adam) const {
  const auto m = io::read_npy(dir_ / "adam" / (name + "_m.npy")).to_float();
  const auto v = io::read_npy(dir_ / "adam" / (name + "_v.npy")).to_float();
  if (m.size() != adam.m().size() || v.size() != adam.v().size())
    fail("{}: optimizer state of '{}' does not match the model", dir_.string(), name);
  adam.m() = m, adam.v() = v;
  adam.step_count() = state_value<std::int64_t>(state_, "adam_steps/" + name, state_file_);
}

}  // namespace retimegs::train
