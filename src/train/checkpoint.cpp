#include "retimegs/train/checkpoint.hpp"

#include <algorithm>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/fnv1a.hpp"
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

// The value at `key` ("rng", "adam_steps/mu", "files/0/size") of a checkpoint's state.json or
// manifest.json `file` as a T; throws Error naming the file and the key when it is missing or of
// another type.
template <typename T>
T state_value(const json& state, const std::string& key, const fs::path& file) {
  const json::json_pointer pointer("/" + key);
  if (!state.contains(pointer)) fail("{}: lacks '{}'", file.string(), key);
  try {
    return state.at(pointer).get<T>();
  } catch (const json::exception&) {
    fail("{}: '{}' has the wrong type: {}", file.string(), key, state.at(pointer).dump());
  }
}

constexpr const char* kManifest = "manifest.json";

// The files under checkpoint `dir` but its manifest, by their names relative to it ('/' between
// folders), sorted.
std::vector<std::string> checkpoint_files(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::recursive_directory_iterator(dir))
    if (!entry.is_directory())
      if (std::string name = entry.path().lexically_relative(dir).generic_string();
          name != kManifest)
        names.push_back(std::move(name));
  std::sort(names.begin(), names.end());
  return names;
}

std::string hex(std::uint64_t hash) {
  return fmt::format("{:016x}", hash);
}

// Throws the refusal of a damaged checkpoint `dir`: what is wrong, and what to do.
template <typename... Args>
[[noreturn]] void refuse_damaged(const fs::path& dir, fmt::format_string<Args...> what,
                                 Args&&... args) {
  fail(
      "{}: {}; the checkpoint is damaged: remove it to resume from the one before, or start "
      "afresh with --force",
      dir.string(), fmt::format(what, std::forward<Args>(args)...));
}

}  // namespace

void write_checkpoint_manifest(const fs::path& dir, int iteration) {
  json files = json::array();
  for (const std::string& name : checkpoint_files(dir))
    files.push_back({{"name", name},
                     {"size", fs::file_size(dir / name)},
                     {"fnv1a64", hex(fnv1a64_file(dir / name))}});
  write_text_file(dir / kManifest, json{{"iteration", iteration}, {"files", files}}.dump(2) + "\n");
}

int verify_checkpoint_manifest(const fs::path& dir) {
  const fs::path path = dir / kManifest;
  if (std::error_code ec; !fs::exists(path, ec))
    fail(
        "{}: the checkpoint has no {} (written by a retimegs before checkpoints carried one): its "
        "files cannot be verified; start afresh with --force",
        dir.string(), kManifest);
  const json manifest = io::read_json_file(path, "checkpoint manifest");
  const int iteration = state_value<int>(manifest, "iteration", path);
  const std::size_t count = state_value<json::array_t>(manifest, "files", path).size();
  std::vector<std::string> listed;
  for (std::size_t i = 0; i < count; ++i) {
    const std::string key = fmt::format("files/{}/", i);
    const auto name = state_value<std::string>(manifest, key + "name", path);
    const auto size = state_value<std::uintmax_t>(manifest, key + "size", path);
    const auto hash = state_value<std::string>(manifest, key + "fnv1a64", path);
    const fs::path file = dir / name;
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) refuse_damaged(dir, "{} is missing", name);
    if (const auto actual = fs::file_size(file, ec); actual != size)
      refuse_damaged(dir,
                     "{} has {} bytes, its manifest says {} (truncated, or another step's file)",
                     name, actual, size);
    if (hex(fnv1a64_file(file)) != hash)
      refuse_damaged(dir, "{} differs from its manifest's hash (another step's file?)", name);
    listed.push_back(name);
  }
  std::sort(listed.begin(), listed.end());
  for (const std::string& name : checkpoint_files(dir))
    if (!std::binary_search(listed.begin(), listed.end(), name))
      refuse_damaged(dir, "{} is not in its manifest (another step's file?)", name);
  return iteration;
}

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
  write_checkpoint_manifest(out.temp_path(), iteration);
  out.commit();
}

Checkpoint::Checkpoint(const fs::path& dir, const model::TimeGrid& grid)
    : dir_(dir), state_file_(dir / "state.json") {
  const int listed = verify_checkpoint_manifest(dir);
  model = model::read_model(dir / "model.rgs");
  if (model.grid.first != grid.first || model.grid.step != grid.step ||
      model.grid.count != grid.count)
    fail(
        "{}: the checkpoint trained {} frames from frame {} (step {}), this run trains {} from "
        "frame {} (step {}): resume with the same --window and --train-frames",
        dir.string(), model.grid.count, model.grid.first, model.grid.step, grid.count, grid.first,
        grid.step);
  state_ = io::read_json_file(state_file_, "checkpoint state");
  iteration = state_value<int>(state_, "iteration", state_file_);
  if (iteration != listed)
    refuse_damaged(dir, "state.json is at iteration {}, its manifest at {}", iteration, listed);
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
