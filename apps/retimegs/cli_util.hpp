#pragma once
// Small argument parsers shared by the sub-commands.
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/playback/times.hpp"
#include "retimegs/train/config.hpp"

namespace retimegs::app {

// "A:B" -> {A, B} (inclusive); throws retimegs::Error naming `flag` on anything else.
std::pair<int, int> parse_range(const std::string& text, const std::string& flag);

// "1,4,7" -> {1, 4, 7}.
std::vector<int> parse_int_list(const std::string& text, const std::string& flag);

// Splits "a,b,c" at commas (empty items refused).
std::vector<std::string> split_list(const std::string& text, const std::string& flag);

}  // namespace retimegs::app

namespace retimegs::app {

// "cam07:0.5,cam12:-1" -> {cam07: 0.5, cam12: -1}: finite numbers of frames by camera (import
// --offsets, synth --time-offsets); the last ':' separates (names may hold ':'). Throws Error
// naming `flag` on a malformed item or a camera given twice.
std::map<std::string, double> parse_camera_values(const std::string& text, const std::string& flag);

// "r,g,b" -> {r, g, b}: exactly `count` finite numbers.
std::vector<float> parse_float_list(const std::string& text, const std::string& flag, int count);

// "A:B:STEP" -> {A, B, STEP}, finite numbers (playback::range_times checks and lists them).
playback::TimeRange parse_time_range(const std::string& text, const std::string& flag);

// --near D: the near plane of a command's model renders, in scene units, into `near` (empty:
// the scene's own, io::scene_near_plane). Resolve it with playback::near_plane().
CLI::Option* add_near_option(CLI::App& cmd, std::optional<double>& near);

// --device cpu|cuda|auto into `device` (default cpu); resolve it with cuda::resolve_device.
CLI::Option* add_device_option(CLI::App& cmd, std::string& device);

}  // namespace retimegs::app

namespace retimegs::app {

// A CLI11 check for an option naming an input file: a FIFO, device or folder is refused
// (core/input_file.hpp) before anything opens it.
CLI::Validator input_file(const std::string& what);

// A CLI11 check for an unsigned option (--seed): digits only, since CLI11 would wrap -1 into
// 2^64 - 1.
CLI::Validator whole_number();

// The parts of scene folder `root` a command reads, for check_output_overlap: scene.json and the
// images, masks, flow and points trees (an output may go into the scene folder beside them).
std::vector<InputPath> scene_inputs(const std::string& root);

}  // namespace retimegs::app

namespace retimegs::app {

// The training settings of `train`, and of each window `slurm` writes: preset `preset`, then the
// keys of `config_file` (when not empty), then --iters, --cap and --seed when given; checked as
// train checks them (Error naming the option or the file's key).
train::TrainConfig training_config(const std::string& preset, const std::string& config_file,
                                   std::optional<int> iters, std::optional<std::size_t> cap,
                                   std::optional<std::uint64_t> seed);

}  // namespace retimegs::app
