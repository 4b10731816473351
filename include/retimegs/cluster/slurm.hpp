#pragma once
// `retimegs slurm`: a long clip trained as time windows on a Slurm cluster (docs/cli.md, README
// "Long clips and Slurm"). Slurm does the scheduling; this writes its job scripts:
//
//   RUN/slurm/window.sh K     window K's steps: `prepare --window` (keeps what the scene already
//                             has), then `train --window` into RUN/windows/K, resuming from its
//                             latest checkpoint when a run is there; a finished window is skipped
//   RUN/slurm/train.sbatch    a job array, task K runs window.sh K
//   RUN/slurm/merge.sbatch    `merge` of the windows' models into RUN/model.rgs, submitted with
//                             --dependency=afterok on the array
//   RUN/slurm/run_local.sh    the same steps in sequence on one machine, without Slurm
//
// Every path in them is absolute (the nodes share the file system, not the working directory);
// the retimegs binary is the one given (the running one). Resubmitting the same scripts resumes.
// Every path and value in them is one word quoted by shell_quote, in the shell's lines and in the
// #SBATCH lines alike, so that no name (a quote, `$(...)`, a `;`, a line break) runs as a command.
#include <filesystem>
#include <string>
#include <vector>

#include "retimegs/io/scene.hpp"
#include "retimegs/io/training_views.hpp"

namespace retimegs::cluster {

// slurm --overlap's default, training intervals: chosen on bench/windows.sh (README "Long clips
// and Slurm": at the same steps per window an overlap spends them on more frames).
constexpr int kDefaultWindowOverlap = 0;

// `count` windows over the clip's training frames (ascending), their numbers of intervals as equal
// as possible: each hands over to the next at a seam, and both train `overlap` intervals beyond it
// (0: the next starts where the previous one ends), so that the merge's fade hands over between
// two reconstructions of the same frames (model/merge.hpp). Throws Error unless 1 <= count <= the
// number of intervals and, with two or more windows, 0 <= 2 overlap <= the shortest window's
// intervals (a window overlaps only its neighbours).
std::vector<io::FrameWindow> split_windows(const std::vector<int>& training_frames, int count,
                                           int overlap = kDefaultWindowOverlap);

struct SlurmJob {
  std::filesystem::path binary;  // the retimegs executable the scripts run
  std::filesystem::path scene;   // scene folder
  std::filesystem::path run;     // RUN
  int windows = 1;
  int overlap = kDefaultWindowOverlap;  // training intervals (split_windows)
  std::string train_frames = "even";    // --train-frames of prepare and train
  // Options given to every window's `train` as they are (--iters N, --preset P, --config FILE,
  // ...).
  std::vector<std::string> train_args;
  // `#SBATCH` lines of the window jobs (train.sbatch), e.g. --partition=gpu, --time=2:00:00,
  // --cpus-per-task=8, --gres=gpu:1.
  std::vector<std::string> sbatch_args;
  // `#SBATCH` lines of the merge job alone (a short CPU job: it needs none of the windows' GPUs).
  std::vector<std::string> merge_sbatch_args;
  // Rewrite scripts of RUN that differ from these (another job's settings); without it they are
  // refused, and scripts that are the same are left as they are (a resubmission).
  bool force = false;
};

struct SlurmScripts {
  std::filesystem::path window, train, merge, local;  // window.sh, train.sbatch, ...
  std::vector<io::FrameWindow> windows;
};

// Writes the scripts (atomically, executable) and RUN/slurm/logs/, with the windows split_windows
// gives for `scene`. Paths are made absolute. Throws Error, before writing anything, naming the
// option for an sbatch argument that is not one option (it must start with '-' and hold no line
// break) and naming RUN when Slurm cannot write logs under it (a line break or a backslash);
// naming the file for a script of RUN that differs unless job.force.
SlurmScripts write_slurm_scripts(const SlurmJob& job, const io::Scene& scene);

struct SubmittedJobs {
  std::string train, merge;  // Slurm job ids
};

// Submits train.sbatch, then merge.sbatch with --dependency=afterok:<train id>, through `sbatch
// --parsable` (found on PATH). Throws Error with sbatch's message when it fails.
SubmittedJobs submit(const SlurmScripts& scripts);

// `text` as one word of a POSIX shell command, single-quoted where needed; sbatch reads the same
// quoting in #SBATCH lines.
std::string shell_quote(const std::string& text);

}  // namespace retimegs::cluster
