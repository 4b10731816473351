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
#include <filesystem>
#include <string>
#include <vector>

#include "retimegs/io/scene.hpp"
#include "retimegs/io/training_views.hpp"

namespace retimegs::cluster {

// `count` windows over the clip's training frames (ascending), each starting where the previous
// one ends, their numbers of intervals as equal as possible. Throws Error unless 1 <= count <=
// the number of intervals.
std::vector<io::FrameWindow> split_windows(const std::vector<int>& training_frames, int count);

struct SlurmJob {
  std::filesystem::path binary;  // the retimegs executable the scripts run
  std::filesystem::path scene;   // scene folder
  std::filesystem::path run;     // RUN
  int windows = 1;
  std::string train_frames = "even";  // --train-frames of prepare and train
  // Options given to every window's `train` as they are (--iters N, --preset P, --config FILE,
  // ...).
  std::vector<std::string> train_args;
  // `#SBATCH` lines of both jobs, e.g. --partition=gpu, --time=2:00:00, --cpus-per-task=8.
  std::vector<std::string> sbatch_args;
  // Rewrite scripts of RUN that differ from these (another job's settings); without it they are
  // refused, and scripts that are the same are left as they are (a resubmission).
  bool force = false;
};

struct SlurmScripts {
  std::filesystem::path window, train, merge, local;  // window.sh, train.sbatch, ...
  std::vector<io::FrameWindow> windows;
};

// Writes the scripts (atomically, executable) and RUN/slurm/logs/, with the windows split_windows
// gives for `scene`. Paths are made absolute. Throws Error naming the option for an sbatch
// argument that is not one option (it must start with '-' and hold no line break), and naming the
// file for a script of RUN that differs unless job.force.
SlurmScripts write_slurm_scripts(const SlurmJob& job, const io::Scene& scene);

struct SubmittedJobs {
  std::string train, merge;  // Slurm job ids
};

// Submits train.sbatch, then merge.sbatch with --dependency=afterok:<train id>, through `sbatch
// --parsable` (found on PATH). Throws Error with sbatch's message when it fails.
SubmittedJobs submit(const SlurmScripts& scripts);

// `text` as one word of a POSIX shell command, single-quoted where needed.
std::string shell_quote(const std::string& text);

}  // namespace retimegs::cluster
