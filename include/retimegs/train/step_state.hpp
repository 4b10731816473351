#pragma once
// What a training step holds on the host whatever its device (train/step.hpp): the model with its
// camera colours, the optimisers, the temporal index, the generator and the iteration, with the
// rules that act on them all at once: initialisation, the index's row order, the per-camera
// colour's Adam step and gauge, the final prune and the checkpoint folder. The CPU step computes
// on this state directly; the CUDA step mirrors it on the device and copies it back at
// checkpoints, strategy calls and the end.
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "retimegs/model/camera_color.hpp"
#include "retimegs/model/model_file.hpp"
#include "retimegs/model/temporal_index.hpp"
#include "retimegs/model/trajectory.hpp"
#include "retimegs/train/adam.hpp"
#include "retimegs/train/background.hpp"
#include "retimegs/train/config.hpp"
#include "retimegs/train/dataset.hpp"
#include "retimegs/train/step.hpp"

namespace retimegs::train {

constexpr int kColorWidth = 6;  // a camera colour's parameters: m[3], then c[3]
constexpr int kPoseWidth = 6;   // a camera pose correction's parameters: ω[3], then τ / E[3]

// Whether the run refines its cameras' poses: config.refine_cameras, or where unset, whether the
// scene's calibration is the user's (io::CalibrationSource).
bool refine_cameras(const TrainConfig& config, const TrainingSet& set);

// Whether the run refines its cameras' clocks: config.refine_clocks, or where unset, whether the
// scene's clocks were estimated (io::ClockSource).
bool refine_clocks(const TrainConfig& config, const TrainingSet& set);

class StepState {
 public:
  StepState(const TrainingSet& set, const TrainConfig& config);

  // Initial primitives (flow-aware, STGS or random fallback) with fresh optimisers and index;
  // returns the note to log.
  std::string initialize();
  void initialize(model::Primitives primitives);
  // The temporal index of the current primitives, after putting the rows (with their Adam state)
  // in its locality order.
  void rebuild_index();
  // Sets the index (of the current rows) and the step's row lists that follow from it.
  void set_index(model::TemporalIndex new_index);
  // The rows a step on view (camera slot c, frame slot i) may touch at its view_time, as one of
  // row_lists() lists: index.rows_at(i) for a view on the grid (list i); for a view between grid
  // slots a and a + 1 (a camera on its own clock), the union of theirs (list frames + its pair's).
  // A retime window's edges lie at training times, so a row visible between two adjacent ones is
  // visible at one of them (the slice leaves out the rest); STGS lists every row at every frame.
  // The unions exist only for the pairs some view falls between (every pair where clocks move):
  // none when every view is on the grid.
  int row_list(int c, int i) const;
  const std::vector<std::int32_t>& rows_of(int list) const;
  int row_lists() const { return index.frames() + int(between_.size()); }
  // train::faint_short_rows removed at config.final_prune_opacity (not for STGS, whose windows
  // are not intervals), with their optimiser state; returns the note to log.
  std::string final_prune();

  // A view (camera slot, frame slot) drawn uniformly from the generator.
  std::pair<int, int> draw_view();
  // The start of a step on view (camera slot c, frame slot i): throws Error unless it is a view of
  // the training set, advances the iteration, sets the schedule's SH degree; returns the step's
  // stats with its iteration and view filled in.
  StepStats begin_step(int c, int i);

  void save_checkpoint(const std::filesystem::path& dir) const;
  void load_checkpoint(const std::filesystem::path& dir);

  // Per-camera colour (model::CameraColor, unless ablated), by training camera slot.
  bool camera_color() const { return !config_.ablate.no_camera_color; }
  model::CameraColor color_of(int c) const;
  // The step's gradient of slot c's (m, c) [kColorWidth], zero between steps.
  float* color_grad(int c) { return &color_grads_[std::size_t(c) * kColorWidth]; }
  // Adam step of slot c's correction on its gradient (then zeroed), then the gauge rule; writes
  // every correction into the model.
  void step_camera_color(int c, double decay);
  // Per-camera pose correction (model/camera_pose.hpp, when refine_cameras), by training camera
  // slot. The camera the steps of slot c draw: the scene's, through its correction.
  bool refine_cameras() const { return *config_.refine_cameras; }
  Camera camera(int c) const;
  model::CameraPose pose_of(int c) const;
  // Whether step number `step` moves the corrections (after config.camera_refine_start), so
  // that its renders add their gradient.
  bool refines_at(int step) const;
  // Adds d loss / d (ω, τ) of slot c (model::camera_pose_vjp) to the step's gradient.
  void add_pose_gradient(int c, const std::array<double, 6>& gradient);
  // The regulariser's gradient, then an Adam step of slot c's correction (gradient then zeroed),
  // then the gauge rule (remove_rig_motion); writes every correction into the model. Returns the
  // regulariser's value.
  double step_camera_pose(int c, double decay);

  // Per-camera clock correction δ (frames, when refine_clocks), by training camera slot. The
  // cameras on the scene's clock (the default one: frame k at time k) anchor it and keep it;
  // every other training camera's clock is refined (all of them, their mean correction held at
  // zero, where no training camera is on the scene's clock: a shift of every clock is a shift of
  // the scene's time).
  bool refine_clocks() const { return *config_.refine_clocks; }
  bool clock_refined(int c) const { return !clock_refined_.empty() && clock_refined_[c]; }
  double clock_of(int c) const { return clock_refined(c) ? clocks_[c] : 0.0; }
  // The time the steps draw view (camera slot c, frame slot i) at, its clock's time plus the
  // correction, and whether that is its training time (TrainingSet::on_grid's rule).
  double view_time(int c, int i) const { return set_.time(c, i) + clock_of(c); }
  bool on_grid(int c, int i) const { return view_time(c, i) == set_.grid.at(i); }
  // Whether step number `step` on slot c moves its correction (after clock_refine_start), so
  // that its render adds d loss / d t (model::slice_time_vjp) with add_time_gradient.
  bool clock_refines_at(int step, int c) const;
  void add_time_gradient(int c, double gradient) { clock_grads_[c] += float(gradient); }
  // An Adam step of slot c's correction (gradient then zeroed), then the gauge rule; writes every
  // refined camera's correction into the model.
  void step_clock(int c, double decay);

  // Whether the steps draw random backgrounds: config.random_background, or its default for the
  // training set (train::random_background).
  bool random_background() const { return *config_.random_background; }
  // The current step's background colour (train/background.hpp); none without random
  // backgrounds.
  std::optional<Rgb> background() const;
  // What camera slot c records of `background`: through its colour map, unless ablated.
  Rgb seen_by(int c, const Rgb& background) const;
  // The clip's ends for model::tie_end_velocities, which each step applies to its active rows
  // after the optimiser step; none without tie_end_velocities and for STGS. Nothing supervises v1
  // of the clip's first interval nor v3 of its last (no flow leads out of the clip), so without
  // the tie they keep their initial values while v2 learns.
  std::optional<model::EndTie<float>> end_tie() const;

  model::Model model;
  Optimizers adam;
  model::TemporalIndex index;
  std::mt19937_64 rng;
  int iteration = 0;

 private:
  void make_optimizers();
  // Subtracts from the pose corrections the motion of the whole rig that they contain.
  void remove_rig_motion();

  const TrainingSet& set_;
  TrainConfig config_;
  // Slot a of every pair (a, a + 1) that some view falls between, ascending, and its rows.
  std::vector<int> between_;
  std::vector<std::vector<std::int32_t>> between_rows_;
  // Per-camera colour: parameters [cameras, kColorWidth] (m then c, training camera slots), their
  // Adam and the step's gradient [cameras, kColorWidth] (zero between steps).
  std::vector<float> colors_, color_grads_;
  Adam color_adam_;
  // Per-camera pose correction likewise: [cameras, kPoseWidth] (ω, then τ in scene extents).
  std::vector<float> poses_, pose_grads_;
  Adam pose_adam_;
  // Per-camera clock correction likewise: [cameras] δ in frames; which slots move.
  std::vector<float> clocks_, clock_grads_;
  Adam clock_adam_;
  std::vector<char> clock_refined_;
};

}  // namespace retimegs::train
