#include "retimegs/cluster/slurm.hpp"

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <iterator>

#include <fmt/format.h>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"

namespace retimegs::cluster {
namespace fs = std::filesystem;

namespace {

std::string quoted(const fs::path& path) {
  return shell_quote(path.string());
}

std::string join_quoted(const std::vector<std::string>& words) {
  std::string out;
  for (const std::string& w : words) out += " " + shell_quote(w);
  return out;
}

// `#SBATCH` lines are read by sbatch, not by a shell, but its reader takes the same quoting as
// shell_quote writes (single quotes, a backslash escaping one character outside them, `#` outside
// quotes starting a comment); a line break ends the line, so an option holding one is refused.
std::string sbatch_lines(const std::vector<std::string>& args, const std::string& flag) {
  std::string out;
  for (const std::string& a : args) {
    if (a.empty() || a[0] != '-' || a.find_first_of("\r\n") != std::string::npos)
      fail("{} '{}': give one sbatch option, e.g. {}=--partition=gpu", flag, a, flag);
    out += "#SBATCH " + shell_quote(a) + "\n";
  }
  return out;
}

// The `--output=` value for the logs folder `logs` and file name pattern `name` (its %A, %a, %j
// are Slurm's). A `%` of the folder is written `%%` so that Slurm keeps it.
std::string sbatch_output(const fs::path& logs, const std::string& name) {
  std::string escaped;
  for (const char c : logs.string()) escaped += c == '%' ? std::string("%%") : std::string(1, c);
  return shell_quote("--output=" + escaped + "/" + name);
}

// A script that is there already is left alone when it is the same, refused when it differs
// (another job's settings) unless `force`.
void write_script(const fs::path& path, const std::string& text, bool force) {
  if (fs::exists(path)) {
    std::ifstream in(path, std::ios::binary);
    const std::string old((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (old == text) return;
    if (!force)
      fail("{}: exists with other settings (pass --force to rewrite the run's scripts)",
           path.string());
  }
  write_text_file(path, text);
  fs::permissions(path, fs::perms::owner_exec | fs::perms::group_exec | fs::perms::others_exec,
                  fs::perm_options::add);
}

// Runs `command` through the shell; returns its standard output and error, and its exit status.
std::pair<std::string, int> run_command(const std::string& command) {
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (!pipe) fail("cannot run '{}'", command);
  std::string output;
  std::array<char, 4096> buffer;
  while (const std::size_t n = std::fread(buffer.data(), 1, buffer.size(), pipe))
    output.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  return {output, WIFEXITED(status) ? WEXITSTATUS(status) : -1};
}

// `text` on one line, for an error message.
std::string one_line(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  for (char& c : text)
    if (c == '\n' || c == '\r') c = ' ';
  return text;
}

// The job id of `sbatch --parsable`'s output: "<id>" or "<id>;<cluster>".
std::string job_id(const std::string& output, const std::string& command) {
  std::string id = output.substr(0, output.find_first_of(";\n"));
  if (id.empty() || id.find_first_not_of("0123456789") != std::string::npos)
    fail("'{}' printed no job id: {}", command, one_line(output));
  return id;
}

}  // namespace

std::string shell_quote(const std::string& text) {
  if (!text.empty() && text.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                              "0123456789_-+=./:,@%") == std::string::npos)
    return text;
  // A quote or backslash is written outside the quotes, escaped: "'\''" and "'\\'". A shell
  // keeps a backslash inside single quotes as it is, Slurm's #SBATCH reader would not.
  std::string out = "'";
  for (const char c : text)
    out += c == '\'' || c == '\\' ? std::string("'\\") + c + "'" : std::string(1, c);
  return out + "'";
}

std::vector<io::FrameWindow> split_windows(const std::vector<int>& training_frames, int count,
                                           int overlap) {
  const int intervals = int(training_frames.size()) - 1;
  if (count < 1 || count > intervals)
    fail("--windows {}: give 1 to {} (the clip's training intervals; a window needs one)", count,
         std::max(intervals, 0));
  std::vector<int> seams;  // indices into training_frames: the clip's ends and the seams
  int shortest = intervals;
  for (int j = 0; j <= count; ++j) seams.push_back(j * intervals / count);
  for (int j = 0; j < count; ++j) shortest = std::min(shortest, seams[j + 1] - seams[j]);
  if (count > 1 && (overlap < 0 || 2 * overlap > shortest))
    fail(
        "--overlap {}: give 0 to {} ({} windows, the shortest of {} training intervals; a window "
        "may overlap only its neighbours)",
        overlap, shortest / 2, count, shortest);
  std::vector<io::FrameWindow> windows;
  for (int j = 0; j < count; ++j)
    windows.push_back(
        {training_frames[std::size_t(j > 0 ? seams[j] - overlap : 0)],
         training_frames[std::size_t(j + 1 < count ? seams[j + 1] + overlap : intervals)]});
  return windows;
}

SlurmScripts write_slurm_scripts(const SlurmJob& job, const io::Scene& scene) {
  const fs::path binary = fs::absolute(job.binary), scene_dir = fs::absolute(job.scene);
  const fs::path run = fs::absolute(job.run), dir = run / "slurm";
  SlurmScripts s;
  s.windows = split_windows(
      io::training_views(scene, io::parse_frame_selection(job.train_frames, "--train-frames"))
          .frames,
      job.windows, job.overlap);
  s.window = dir / "window.sh";
  s.train = dir / "train.sbatch";
  s.merge = dir / "merge.sbatch";
  s.local = dir / "run_local.sh";
  // A line break cannot be written in an #SBATCH line and a backslash turns Slurm's --output
  // patterns off: Slurm cannot keep its logs under such a run folder.
  if (run.string().find_first_of("\r\n\\") != std::string::npos)
    fail(
        "--out {}: Slurm cannot write its logs under a path holding a line break or a backslash; "
        "choose another run folder",
        run.string());
  const std::string train_sbatch = sbatch_lines(job.sbatch_args, "--sbatch-arg"),
                    merge_sbatch = sbatch_lines(job.merge_sbatch_args, "--merge-sbatch-arg"),
                    train_output = sbatch_output(dir / "logs", "train_%A_%a.out"),
                    merge_output = sbatch_output(dir / "logs", "merge_%j.out");
  fs::create_directories(dir / "logs");

  std::string windows, models;
  for (std::size_t k = 0; k < s.windows.size(); ++k) {
    windows += fmt::format(" {}:{}", s.windows[k].first, s.windows[k].last);
    models += " " + quoted(run / "windows" / std::to_string(k) / "model.rgs");
  }
  const std::string bin = quoted(binary), frames = shell_quote(job.train_frames);
  // Threads: the CPUs Slurm gave the task, all cores outside Slurm. Device: the node's GPU where
  // the job was given one (--sbatch-arg=--gres=gpu:1; Slurm shows the task only its own), else
  // the CPU.
  write_script(
      s.window,
      fmt::format(R"SH(#!/bin/bash
# Window K of {run}: prepare its frames (files the scene has are kept), then train it, resuming
# from its latest checkpoint when a run is there. A finished window is left as it is.
# No array is expanded empty: bash before 4.4 calls that unbound under `set -u`.
set -euo pipefail
windows=({windows})
k=${{1:?usage: window.sh K}}
window=${{windows[$k]}}
out={run}/windows/$k
if [ -e "$out/model.rgs" ]; then echo "window $k ($window): done"; exit 0; fi
threads=${{SLURM_CPUS_PER_TASK:-0}}
echo "window $k ($window): start $(date +%s.%N)"
{bin} prepare --scene {scene} --train-frames {frames} --window "$window" --threads "$threads"
resume=
if [ -e "$out/config.json" ]; then resume=--resume; fi
{bin} train --scene {scene} --out "$out" --train-frames {frames} --window "$window" \
  --threads "$threads" --device auto{train_args} $resume
echo "window $k ($window): end $(date +%s.%N)"
)SH",
                  fmt::arg("run", quoted(run)), fmt::arg("windows", windows.substr(1)),
                  fmt::arg("bin", bin), fmt::arg("scene", quoted(scene_dir)),
                  fmt::arg("frames", frames), fmt::arg("train_args", join_quoted(job.train_args))),
      job.force);
  const std::string merge_command =
      fmt::format("{} merge --force --out {}{}", bin, quoted(run / "model.rgs"), models);
  write_script(s.train,
               fmt::format(R"SH(#!/bin/bash
#SBATCH --job-name=retimegs-train
#SBATCH --array=0-{last}
#SBATCH {output}
{sbatch}set -euo pipefail
exec {window} "$SLURM_ARRAY_TASK_ID"
)SH",
                           fmt::arg("last", s.windows.size() - 1), fmt::arg("output", train_output),
                           fmt::arg("sbatch", train_sbatch), fmt::arg("window", quoted(s.window))),
               job.force);
  write_script(s.merge,
               fmt::format(R"SH(#!/bin/bash
#SBATCH --job-name=retimegs-merge
#SBATCH {output}
{sbatch}set -euo pipefail
{merge}
)SH",
                           fmt::arg("output", merge_output), fmt::arg("sbatch", merge_sbatch),
                           fmt::arg("merge", merge_command)),
               job.force);
  write_script(s.local,
               fmt::format(R"SH(#!/bin/bash
# The steps of train.sbatch and merge.sbatch in sequence on this machine (no Slurm needed).
set -euo pipefail
for k in $(seq 0 {last}); do
  {window} "$k"
done
{merge}
)SH",
                           fmt::arg("last", s.windows.size() - 1),
                           fmt::arg("window", quoted(s.window)), fmt::arg("merge", merge_command)),
               job.force);
  return s;
}

SubmittedJobs submit(const SlurmScripts& scripts) {
  SubmittedJobs jobs;
  const std::string train = "sbatch --parsable " + quoted(scripts.train);
  auto [out, status] = run_command(train);
  if (status != 0) fail("'{}' failed (exit {}): {}", train, status, one_line(out));
  jobs.train = job_id(out, train);
  const std::string merge = fmt::format("sbatch --parsable --dependency=afterok:{} {}", jobs.train,
                                        quoted(scripts.merge));
  std::tie(out, status) = run_command(merge);
  if (status != 0) fail("'{}' failed (exit {}): {}", merge, status, one_line(out));
  jobs.merge = job_id(out, merge);
  return jobs;
}

}  // namespace retimegs::cluster
