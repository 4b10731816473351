#include "cli_util.hpp"

#include <charconv>
#include <cmath>
#include <string>

#include "retimegs/core/error.hpp"
#include "retimegs/core/input_file.hpp"
#include "retimegs/io/training_views.hpp"

namespace retimegs::app {

namespace {
int parse_int(const std::string& item, const std::string& flag, const std::string& whole) {
  int value = 0;
  const auto [end, ec] = std::from_chars(item.data(), item.data() + item.size(), value);
  if (ec != std::errc() || end != item.data() + item.size() || item.empty())
    fail("{}: '{}' is not an integer (in '{}')", flag, item, whole);
  return value;
}
}  // namespace

std::vector<std::string> split_list(const std::string& text, const std::string& flag) {
  std::vector<std::string> items;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = text.find(',', start);
    items.push_back(text.substr(start, comma - start));
    if (items.back().empty()) fail("{}: empty item in '{}'", flag, text);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return items;
}

std::pair<int, int> parse_range(const std::string& text, const std::string& flag) {
  const std::size_t colon = text.find(':');
  if (colon == std::string::npos) fail("{}: expected A:B, got '{}'", flag, text);
  return {parse_int(text.substr(0, colon), flag, text),
          parse_int(text.substr(colon + 1), flag, text)};
}

std::vector<int> parse_int_list(const std::string& text, const std::string& flag) {
  std::vector<int> values;
  for (const std::string& item : split_list(text, flag))
    values.push_back(parse_int(item, flag, text));
  return values;
}

}  // namespace retimegs::app

namespace retimegs::app {

namespace {
double parse_double(const std::string& item, const std::string& flag, const std::string& whole) {
  std::size_t end = 0;
  double value = 0;
  try {
    value = std::stod(item, &end);
  } catch (const std::exception&) {
    end = 0;
  }
  if (end != item.size() || item.empty() || !std::isfinite(value))
    fail("{}: '{}' is not a finite number (in '{}')", flag, item, whole);
  return value;
}
}  // namespace

std::map<std::string, double> parse_camera_values(const std::string& text,
                                                  const std::string& flag) {
  std::map<std::string, double> values;
  for (const std::string& item : split_list(text, flag)) {
    const std::size_t colon = item.rfind(':');
    if (colon == std::string::npos || colon == 0 || colon + 1 == item.size())
      fail("{}: expected CAMERA:X (X a number of frames), got '{}'", flag, item);
    const std::string name = item.substr(0, colon);
    if (!values.emplace(name, parse_double(item.substr(colon + 1), flag, item)).second)
      fail("{}: camera '{}' is given twice", flag, name);
  }
  return values;
}

std::vector<float> parse_float_list(const std::string& text, const std::string& flag, int count) {
  std::vector<float> values;
  for (const std::string& item : split_list(text, flag))
    values.push_back(float(parse_double(item, flag, text)));
  if (int(values.size()) != count) fail("{}: expected {} values, got '{}'", flag, count, text);
  return values;
}

playback::TimeRange parse_time_range(const std::string& text, const std::string& flag) {
  std::vector<double> parts;
  std::size_t start = 0;
  for (int i = 0; i < 3; ++i) {
    const std::size_t colon = text.find(':', start);
    if ((i < 2) == (colon == std::string::npos))
      fail("{}: expected A:B:STEP, got '{}'", flag, text);
    parts.push_back(parse_double(text.substr(start, colon - start), flag, text));
    start = colon + 1;
  }
  return {parts[0], parts[1], parts[2]};
}

CLI::Option* add_near_option(CLI::App& cmd, std::optional<double>& near) {
  return cmd.add_option(
      "--near", near,
      fmt::format(
          "near plane in scene units: Gaussians closer to the camera are not drawn "
          "(default: {:g} % of the scene's extent, 1.1 x the training cameras' radius; on a "
          "dome it keeps a rig camera's own body, which the other cameras see, out of "
          "its renders)",
          100 * io::kNearPlaneFraction));
}

CLI::Option* add_device_option(CLI::App& cmd, std::string& device) {
  device = "auto";  // a user with a GPU computes on it
  return cmd
      .add_option("--device", device,
                  "where to compute: cpu, cuda (an NVIDIA GPU; needs a build with the CUDA "
                  "backend) or auto (cuda when the build has it and a GPU is present, else cpu); "
                  "the log names the one that ran")
      ->capture_default_str();
}

}  // namespace retimegs::app

namespace retimegs::app {

CLI::Validator input_file(const std::string& what) {
  return CLI::Validator(
      [what](std::string& path) {
        try {
          check_input_file(path, what);
        } catch (const Error& e) {
          return std::string(e.what());
        }
        return std::string();
      },
      "FILE");
}

CLI::Validator whole_number() {
  return CLI::Validator(
      [](std::string& text) {
        if (!text.empty() && text.find_first_not_of("0123456789") == std::string::npos)
          return std::string();
        return fmt::format("must be a whole number >= 0, got '{}'", text);
      },
      "UINT");
}

std::vector<InputPath> scene_inputs(const std::string& root) {
  if (root.empty()) return {};
  const std::filesystem::path r = root;
  std::vector<InputPath> inputs = {{r / "scene.json", "scene file"}};
  for (const char* part : {"images", "masks", "flow", "points"})
    inputs.push_back({r / part, fmt::format("scene's {} folder", part), true});
  return inputs;
}

}  // namespace retimegs::app

namespace retimegs::app {

train::TrainConfig training_config(const std::string& preset, const std::string& config_file,
                                   std::optional<int> iters, std::optional<std::size_t> cap,
                                   std::optional<std::uint64_t> seed) {
  train::TrainConfig config = train::with_preset(train::TrainConfig{}, preset, "--preset");
  if (!config_file.empty())
    config =
        train::config_from_json(read_text_file(config_file, "config file"), config, config_file);
  if (iters) config.iters = *iters;
  if (cap) config.cap = *cap;
  if (seed) config.seed = *seed;
  train::check_config(config, "--iters / --cap");
  return config;
}

}  // namespace retimegs::app
