// retimegs synth --preset NAME --out SCENE [--cameras N] [--frames K] [--size WxH] [--seed S]
//                [--time-offsets CAM:X,...] [--unrecorded-offsets]
//                [--perturb-calibration ROT_DEG,TRANS_FRAC,FOCAL_FRAC] [--threads T] [--force]
#include <charconv>
#include <memory>
#include <string>
#include <tuple>
#include <utility>

#include <fmt/format.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/io/perturb_calibration.hpp"
#include "retimegs/synth/synth.hpp"

namespace retimegs::app {

namespace {

// "256x192" -> {256, 192}; the sizes themselves are checked by the library.
std::pair<int, int> parse_size(const std::string& text) {
  const auto x = text.find('x');
  int width = 0, height = 0;
  const char* end = text.data() + text.size();
  const bool ok = x != std::string::npos &&
                  std::from_chars(text.data(), text.data() + x, width).ptr == text.data() + x &&
                  std::from_chars(text.data() + x + 1, end, height).ptr == end && x > 0 &&
                  x + 1 < text.size();
  if (!ok) fail("--size: expected WIDTHxHEIGHT (e.g. 256x192), got '{}'", text);
  return {width, height};
}

}  // namespace

void add_synth_command(CLI::App& app) {
  struct Args {
    synth::SynthOptions options;
    std::string out, size = "256x192", time_offsets, perturb;
    int threads = 0;
    bool unrecorded = false;
  };
  auto args = std::make_shared<Args>();
  std::string presets = "scene preset:";
  for (const auto& p : synth::synth_presets())
    presets += fmt::format("\n  {}: {}", p.name, p.description);

  CLI::App* cmd = app.add_subcommand(
      "synth",
      "Write a procedural multi-view dynamic test scene (images, masks, exact flows for strides 1 "
      "and 2, per-frame points), rendered by an analytic ray caster.");
  cmd->add_option("--preset", args->options.preset, presets)->required();
  cmd->add_option("--out", args->out, "scene folder to write (must not exist unless --force)")
      ->required();
  cmd->add_option("--cameras", args->options.cameras, "cameras on a ring around the scene")
      ->capture_default_str();
  cmd->add_option("--frames", args->options.frames, "number of frames")->capture_default_str();
  cmd->add_option("--size", args->size, "image size WIDTHxHEIGHT")->capture_default_str();
  cmd->add_option("--seed", args->options.seed,
                  "seed of object phases, colours, textures and camera jitter")
      ->capture_default_str()
      ->check(whole_number());
  cmd->add_option("--time-offsets", args->time_offsets,
                  "per-camera clock offsets CAM:X,... in frames (e.g. cam01:0.5): CAM's frame k, "
                  "mask and flows show the scene at time k + X; scene.json records them as the "
                  "cameras' time_offset");
  cmd->add_flag("--unrecorded-offsets", args->unrecorded,
                "render the --time-offsets but leave them out of scene.json (footage whose "
                "offsets nobody measured)");
  cmd->add_option("--perturb-calibration", args->perturb,
                  "ROT_DEG,TRANS_FRAC,FOCAL_FRAC: scene.json gets each camera turned by up to "
                  "ROT_DEG degrees, moved by up to TRANS_FRAC of the scene extent and its focal "
                  "length scaled by up to 1 +- FOCAL_FRAC (drawn from --seed; each at least half "
                  "its bound); the true cameras go to calibration_true.json (a rig file)");
  cmd->add_option("--threads", args->threads, "worker threads (0 = all cores)")
      ->capture_default_str();
  cmd->add_flag("--force", args->options.force, "replace an existing output folder");
  cmd->callback([args] {
    set_threads(args->threads);
    std::tie(args->options.width, args->options.height) = parse_size(args->size);
    if (!args->time_offsets.empty())
      args->options.time_offsets = parse_camera_values(args->time_offsets, "--time-offsets");
    if (args->unrecorded && args->time_offsets.empty())
      fail("--unrecorded-offsets: give the offsets with --time-offsets");
    args->options.record_offsets = !args->unrecorded;
    if (!args->perturb.empty())
      args->options.perturb_calibration =
          io::parse_calibration_perturbation(args->perturb, "--perturb-calibration");
    synth::synthesize_scene(args->options, args->out);
  });
}

}  // namespace retimegs::app
