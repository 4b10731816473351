#include "retimegs/train_run/run.hpp"

#include <algorithm>
#include <fstream>
#include <numbers>
#include <vector>

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/folder_lock.hpp"
#include "retimegs/core/input_file.hpp"
#include "retimegs/core/interrupt.hpp"
#include "retimegs/core/memory.hpp"
#include "retimegs/core/progress.hpp"
#include "retimegs/io/coverage.hpp"
#include "retimegs/model/window.hpp"
#include "retimegs/train/background.hpp"
#include "retimegs/train/dataset.hpp"
#include "retimegs/train/step.hpp"
#include "retimegs/train/step_state.hpp"
#include "retimegs/train_run/load_training_set.hpp"

namespace retimegs::train {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// A kill leaves the temporary sibling of the file or checkpoint being written
// (".<name>.tmp<pid>", core/atomic_file.hpp); with the run folder locked none is in use.
void remove_stale_temporaries(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return;
  std::vector<fs::path> stale;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.size() > 1 && name[0] == '.' && name.find(".tmp") != std::string::npos)
      stale.push_back(e.path());
  }
  for (const fs::path& p : stale) {
    fs::remove_all(p, ec);
    if (ec)
      fail("{}: cannot remove a temporary left by an interrupted run: {}", p.string(),
           ec.message());
    spdlog::info("removed {} (left by an interrupted run)", p.string());
  }
}

// The folders RUN/checkpoints/iter_NNNNNN, oldest first.
std::vector<fs::path> checkpoint_folders(const fs::path& checkpoints) {
  std::vector<fs::path> found;
  std::error_code ec;
  if (fs::is_directory(checkpoints, ec))
    for (const auto& e : fs::directory_iterator(checkpoints))
      if (e.is_directory() && e.path().filename().string().rfind("iter_", 0) == 0)
        found.push_back(e.path());
  std::sort(found.begin(), found.end(),
            [](const fs::path& a, const fs::path& b) { return a.filename() < b.filename(); });
  return found;
}

// Keeps the lines of log.jsonl up to `iteration`: a run resumed from a checkpoint writes the
// steps after it again.
void trim_log(const fs::path& log, int iteration) {
  std::error_code ec;
  if (!fs::is_regular_file(log, ec)) return;
  std::ifstream in(log);
  std::string line, kept;
  while (std::getline(in, line)) {
    const json entry = json::parse(line, nullptr, /*allow_exceptions=*/false);
    if (entry.is_object() && entry.value("iteration", 0) <= iteration) kept += line + "\n";
  }
  in.close();
  write_text_file(log, kept);
}

// A run folder that holds a run: its model, checkpoints or config.
bool holds_run(const fs::path& out) {
  std::error_code ec;
  return fs::exists(out / "model.rgs", ec) || fs::exists(out / "checkpoints", ec) ||
         fs::exists(out / "config.json", ec);
}

// The refusal of a folder that holds a run, unless resumed or forced.
[[noreturn]] void refuse_existing_run(const fs::path& out) {
  fail(
      "{}: a training run is already there (pass --resume to continue it, --force to start "
      "afresh, or choose another folder)",
      out.string());
}

// The run folder for the run's lifetime: created and locked (core/folder_lock.hpp), its
// temporaries removed, its configuration and the checkpoint to resume from resolved. Until
// commit(), a failure removes the folder if this run created it (a failure before config.json is
// written leaves nothing).
class RunFolder {
 public:
  explicit RunFolder(const TrainRun& run)
      : out_(run.out), cleanup_{out_, !fs::exists(out_)}, lock_(create(out_), "run folder") {
    remove_stale_temporaries(out_);
    remove_stale_temporaries(checkpoints());
    config = run.config;
    if (run.resume && fs::exists(out_ / "config.json")) {
      // A config.json without random_background, refine_cameras or refine_clocks predates the
      // key: its run trained over black, with the cameras and their clocks as given.
      TrainConfig before_keys;
      before_keys.random_background = false;
      before_keys.refine_cameras = false;
      before_keys.refine_clocks = false;
      config = config_from_json(read_text_file(out_ / "config.json", "run config"), before_keys,
                                (out_ / "config.json").string());
      if (const auto found = checkpoint_folders(checkpoints()); !found.empty())
        latest = found.back();
      if (run.iters) {
        config.iters = *run.iters;  // continue to the new total
        check_config(config, "--iters");
      }
    } else if (run.resume) {
      // Killed before config.json was written: nothing was trained, so the run starts afresh.
      if (fs::exists(checkpoints()) || fs::exists(out_ / "model.rgs"))
        fail("{}: cannot resume: the run has no config.json (start afresh with --force)",
             out_.string());
      spdlog::info("{}: nothing to resume yet (no config.json): starting afresh", out_.string());
    } else if (holds_run(out_)) {
      if (!run.force) refuse_existing_run(out_);
      for (const char* name : {"model.rgs", "config.json", "log.jsonl", "checkpoints"})
        fs::remove_all(out_ / name);
    }
  }
  // The run's configuration is in the folder: from here on the folder stays.
  void commit() { cleanup_.armed = false; }

  fs::path checkpoints() const { return out_ / "checkpoints"; }
  fs::path checkpoint(int iteration) const {
    return checkpoints() / fmt::format("iter_{:06d}", iteration);
  }
  fs::path file(const char* name) const { return out_ / name; }

  // Writes the step's checkpoint at its iteration, then removes all but the latest
  // config.checkpoint_keep (0: none).
  void save_checkpoint(const TrainingStep& step) const {
    step.save_checkpoint(checkpoint(step.iteration()));
    const std::vector<fs::path> all = checkpoint_folders(checkpoints());
    const std::size_t keep = std::size_t(config.checkpoint_keep);
    for (std::size_t i = 0; keep > 0 && i + keep < all.size(); ++i) {
      std::error_code ec;
      fs::remove_all(all[i], ec);
      if (ec) fail("{}: cannot remove an old checkpoint: {}", all[i].string(), ec.message());
    }
  }

  TrainConfig config;
  fs::path latest;  // the checkpoint to resume from, or empty

 private:
  static const fs::path& create(const fs::path& out) {
    std::error_code ec;
    fs::create_directories(out, ec);
    if (ec) fail("{}: cannot create the run folder: {}", out.string(), ec.message());
    return out;
  }

  // A member, so that it also runs when the constructor throws (after lock_ has unlocked).
  struct RemoveUnlessCommitted {
    const fs::path& dir;
    bool armed;
    ~RemoveUnlessCommitted() {
      std::error_code ignored;
      if (armed) fs::remove_all(dir, ignored);
    }
  };

  fs::path out_;
  RemoveUnlessCommitted cleanup_;
  FolderLock lock_;
};

// log.jsonl: a line every 10 steps and at every step that relocated or stretched, with the
// mean stage times of the steps since the previous line.
class TrainingLog {
 public:
  explicit TrainingLog(fs::path path) : path_(std::move(path)), out_(path_, std::ios::app) {
    if (!out_) fail("{}: cannot open the training log", path_.string());
  }

  void add(const StepStats& s) {
    since_ += s.seconds, ++steps_;
    if (!(s.iteration % 10 == 0 || s.relocated || s.stretched)) return;
    const double ms = 1e3 / steps_;
    out_ << json{{"iteration", s.iteration},
                 {"camera", s.camera},
                 {"frame", s.frame},
                 {"loss", s.loss},
                 {"image_loss", s.image_loss},
                 {"flow_loss", s.flow_loss},
                 {"flow_weight", s.flow_weight},
                 {"psnr", s.psnr},
                 {"primitives", s.primitives},
                 {"active", s.active},
                 {"relocated", s.relocated},
                 {"added", s.added},
                 {"stretched", s.stretched},
                 {"pruned", s.pruned},
                 {"ms_per_step",
                  {{"evaluate", since_.slice * ms},
                   {"render_forward", since_.render_forward * ms},
                   {"losses", since_.losses * ms},
                   {"render_backward", since_.render_backward * ms},
                   {"evaluate_backward", since_.slice_backward * ms},
                   {"optimizer", since_.optimizer * ms},
                   {"other", since_.other() * ms},
                   {"total", since_.total * ms}}}}
                .dump()
         << "\n";
    since_ = {}, steps_ = 0;
  }

  void flush() {
    out_.flush();
    check_written(out_, path_);
  }

 private:
  fs::path path_;
  std::ofstream out_;
  StageSeconds since_;  // summed over the steps since the last line
  int steps_ = 0;
};

// The log's word on the run's background: which, and why (`given`: the config set
// random_background rather than leaving it to the capture's masks).
std::string describe_background(bool random, bool given) {
  const char* why = given    ? "as the config's random_background sets"
                    : random ? "the capture has no masks; the config's random_background chooses"
                             : "the capture has masks; the config's random_background chooses";
  return fmt::format("{} ({})", random ? "a random colour per step" : "black", why);
}

// What the training set's points cover (io/coverage.hpp), and its warnings, in the log: a sparse
// rig's fog is said before the run, not found in its scores. Test cameras count every pixel (their
// masks are not part of the set). Nothing when the frames measured have no points (initialize's
// note says so).
void log_coverage(const TrainingSet& set) {
  io::CoverageCounter coverage(set.scene);
  std::size_t measured = 0;
  for (const std::size_t f : io::coverage_frames(set.frames.size())) {
    if (!set.points[f]) continue;
    ++measured;
    std::vector<const Image*> masks(set.scene.cameras.size(), nullptr);
    for (std::size_t c = 0; c < set.cameras.size(); ++c)
      if (!set.masks[c].empty() && set.masks[c][f]) masks[set.cameras[c]] = &*set.masks[c][f];
    coverage.add(*set.points[f], masks);
  }
  if (measured == 0) return;
  const io::Coverage result = coverage.result();
  spdlog::info("{}", io::describe_coverage(set.scene, result));
  for (const std::string& line : io::coverage_warnings(set.scene, result)) spdlog::warn("{}", line);
}

// The log's word on the cameras' calibration (`given`: the config set refine_cameras rather than
// leaving it to the scene's calibration source).
std::string describe_refinement(const TrainConfig& config, bool given) {
  if (!*config.refine_cameras) return "taken as calibrated (the config's refine_cameras)";
  return fmt::format("pose corrections learned from iteration {} ({})",
                     config.scaled(config.camera_refine_start),
                     given ? "the config's refine_cameras"
                           : "the calibration is the user's: scene.json calibration");
}

// Each training camera's learned correction (model/camera_pose.hpp): the angle it turned and the
// distance its centre moved (|τ|), in % of the scene extent.
void log_camera_poses(const model::Model& model, const TrainingSet& set) {
  for (const int c : set.cameras) {
    const std::string& name = set.scene.cameras[c].name;
    const model::CameraPose* pose = model::find_camera_pose(model, name);
    if (!pose) continue;
    const Eigen::Vector3d w(pose->rotation.data()), t(pose->translation.data());
    spdlog::info("camera {}: turned {:.3f}°, moved {:.3f} % of the scene extent", name,
                 w.norm() * 180 / std::numbers::pi, 100 * t.norm() / set.scene_extent);
  }
}

// Each refined camera's clock: its offset as the scene gave it (the mean of its frames' offsets
// from their positions) and as training learned it, in frames.
void log_camera_clocks(const model::Model& model, const TrainingSet& set) {
  for (const int c : set.cameras) {
    const std::string& name = set.scene.cameras[c].name;
    const auto it = model.camera_clocks.find(name);
    if (it == model.camera_clocks.end()) continue;
    double given = 0;
    for (const int frame : set.frames) given += io::frame_time(set.scene, c, frame) - frame;
    given /= double(set.frames.size());
    spdlog::info("camera {}: clock offset {:+.3f} frames, given {:+.3f} (moved {:+.3f})", name,
                 given + it->second, given, it->second);
  }
}

// The progress line's smoothed loss and PSNR (exponential moving average).
struct Smoothed {
  double loss = 0, psnr = 0;
  bool started = false;
  void add(const StepStats& s) {
    constexpr double kSmoothing = 0.05;
    loss = started ? (1 - kSmoothing) * loss + kSmoothing * s.loss : s.loss;
    psnr = started ? (1 - kSmoothing) * psnr + kSmoothing * s.psnr : s.psnr;
    started = true;
  }
};

}  // namespace

model::Model train(const io::Scene& scene, const TrainRun& run) {
  std::error_code ec;
  if (fs::exists(run.out, ec) && !fs::is_directory(run.out, ec))
    fail("{}: the run folder is a file", run.out.string());
  // Checked again once the folder is locked; here so that a refusal comes before the images load.
  if (!run.resume && !run.force && holds_run(run.out)) refuse_existing_run(run.out);
  // Every input is read before the run folder is created or changed: a bad scene leaves nothing.
  const TrainingSet set = load_training_set(scene, run.frames, run.window, run.downscale);
  RunFolder folder(run);
  // Settled here, so that config.json records what the run does whatever the capture becomes.
  const bool background_given = folder.config.random_background.has_value();
  folder.config.random_background = random_background(folder.config, set);
  const std::string background =
      describe_background(*folder.config.random_background, background_given);
  const bool refine_given = folder.config.refine_cameras.has_value();
  folder.config.refine_cameras = refine_cameras(folder.config, set);
  const bool clocks_given = folder.config.refine_clocks.has_value();
  folder.config.refine_clocks = refine_clocks(folder.config, set);
  const TrainConfig& config = folder.config;

  const std::unique_ptr<TrainingStep> owned_step = make_step(set, config, run.device);
  TrainingStep& step = *owned_step;
  if (!folder.latest.empty()) {
    step.load_checkpoint(folder.latest);
    if (step.iteration() > config.iters)
      fail("{}: the run is at step {} already; --iters {} must not be smaller", run.out.string(),
           step.iteration(), config.iters);
    trim_log(folder.file("log.jsonl"), step.iteration());
    if (run.iters) write_text_file(folder.file("config.json"), to_json(config) + "\n");
    spdlog::info("resuming from {} (iteration {} of {})", folder.latest.string(), step.iteration(),
                 config.iters);
  } else {
    const std::string note = step.initialize();
    fs::remove(folder.file("log.jsonl"), ec);  // of a run killed before its first checkpoint
    write_text_file(folder.file("config.json"), to_json(config) + "\n");
    spdlog::info("{}", note);
    log_coverage(set);
  }
  folder.commit();
  spdlog::info(
      "training {} primitives (cap {}) on {} cameras x {} frames ({:.0f} MB of images), {} flow "
      "files, {} iterations, on {}; background: {}",
      step.primitive_count(), config.cap, set.cameras.size(), set.frames.size(),
      double(set.image_bytes()) / 1e6, set.flow_files(), config.iters, cuda::describe(run.device),
      background);
  if (*config.refine_cameras || set.scene.calibration == io::CalibrationSource::kUser)
    spdlog::info("cameras: {}", describe_refinement(config, refine_given));
  if (io::has_own_clocks(set.scene)) {
    std::size_t off = 0;
    for (std::size_t c = 0; c < set.cameras.size(); ++c)
      for (std::size_t i = 0; i < set.frames.size(); ++i) off += !set.on_grid(int(c), int(i));
    spdlog::info(
        "own clocks: {} of {} training views lie off the training times (scene.json time_offset, "
        "frame_times): one render of all primitives at each one's own time, image loss only",
        off, set.cameras.size() * set.frames.size());
  }
  if (*config.refine_clocks || set.scene.clock_source == io::ClockSource::kEstimated)
    spdlog::info("clocks: {}",
                 !*config.refine_clocks
                     ? std::string("taken as given (the config's refine_clocks)")
                     : fmt::format("corrections of the cameras off the scene's clock learned from "
                                   "iteration {} ({})",
                                   config.scaled(config.clock_refine_start),
                                   clocks_given ? "the config's refine_clocks"
                                                : "the clocks were estimated: scene.json clocks"));

  TrainingLog log(folder.file("log.jsonl"));
  // The loop handles Ctrl-C itself (below): its bar must not throw.
  Progress progress("train", std::size_t(config.iters), run.progress, /*interruptible=*/false);
  progress.tick(std::size_t(step.iteration()));
  Smoothed smoothed;
  while (step.iteration() < config.iters) {
    if (const int signal = interrupt_signal()) {
      // The step that was running when the signal came has finished: keep it.
      progress.finish();
      log.flush();
      const int it = step.iteration();
      if (it == 0)
        throw Interrupted(signal, fmt::format("interrupted by {} before the first step; resume "
                                              "with --resume (it starts afresh)",
                                              signal_name(signal)));
      if (!fs::exists(folder.checkpoint(it))) folder.save_checkpoint(step);
      throw Interrupted(signal,
                        fmt::format("interrupted at step {}; checkpoint written to {}; resume with "
                                    "--resume",
                                    it, folder.checkpoint(it).string()));
    }
    const StepStats s = step.step();
    log.add(s);
    smoothed.add(s);
    progress.tick(
        1, fmt::format("loss {:.4f} psnr {:.2f} n {}", smoothed.loss, smoothed.psnr, s.primitives));
    // Also at the last step, before the final prune: a later --resume --iters N continues from
    // there.
    if (s.iteration % config.checkpoint_every == 0 || s.iteration == config.iters) {
      log.flush();
      folder.save_checkpoint(step);
    }
  }
  progress.finish();
  log.flush();
  spdlog::info("{}", step.finish());
  if (*config.refine_cameras) log_camera_poses(step.host_model(), set);
  if (*config.refine_clocks) log_camera_clocks(step.host_model(), set);
  // A window's model is stored on the clip's grid with its window, for merge.
  const model::Model model =
      set.clip_grid ? model::with_window(step.host_model(), *set.clip_grid, config.model_config())
                    : step.host_model();
  model::write_model(folder.file("model.rgs"), model);
  const std::size_t gpu_peak = step.device_memory_peak();
  spdlog::info("model: {} ({} primitives); peak memory {:.0f} MB{}",
               folder.file("model.rgs").string(), model.primitives.size(),
               double(peak_rss_bytes()) / 1e6,
               gpu_peak ? fmt::format(", GPU {:.0f} MB (the step's buffers)", gpu_peak / 1e6) : "");
  return model;
}

}  // namespace retimegs::train
