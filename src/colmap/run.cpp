// The COLMAP command line (run.hpp).
#include "retimegs/colmap/run.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <thread>

#include <fmt/format.h>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/executable.hpp"
#include "retimegs/core/interrupt.hpp"

extern char** environ;

namespace retimegs::colmap {
namespace fs = std::filesystem;

namespace {

// How often a running command is checked for its end and for a signal: unnoticeable beside
// commands that take seconds.
constexpr std::chrono::milliseconds kWaitPoll{20};

// The line of a log that best explains a failure: the last one that mentions an error (glog's
// "Check failed", "ERROR", boost's "error"), else the last non-empty one.
std::string last_error_line(const fs::path& log) {
  std::ifstream in(log);
  std::string line, last, last_error;
  while (std::getline(in, line)) {
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
    if (line.empty() || line.rfind("*** ", 0) == 0 || line.rfind("    @ ", 0) == 0) continue;
    last = line;
    std::string lower = line;
    std::transform(lower.begin(), lower.end(), lower.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    if (lower.find("error") != std::string::npos ||
        lower.find("check failed") != std::string::npos ||
        lower.find("failed") != std::string::npos)
      last_error = line;
  }
  return last_error.empty() ? (last.empty() ? "(no output)" : last) : last_error;
}

// What a COLMAP failure means, in a user's words, from its error line; empty when the line says
// nothing known. Its bundle adjuster's check fails (glog "Check failed: bundle_adjuster.Solve")
// when the images share too few matched features to solve for the points.
std::string failure_reason(const std::string& line) {
  if (line.find("bundle_adjuster") != std::string::npos)
    return ": its bundle adjustment could not solve, which happens when the cameras share too few "
           "matched features (too little texture, overlap or resolution)";
  return {};
}

}  // namespace

fs::path find_colmap(const ColmapOptions& options) {
  const fs::path exe = find_executable(options.executable);
  if (exe.empty())
    fail("COLMAP not found: install the Debian package colmap (scripts/setup.sh does)");
  return exe;
}

bool colmap_available(const ColmapOptions& options) {
  return !find_executable(options.executable).empty();
}

void run_colmap(const fs::path& exe, const std::string& step, const std::vector<std::string>& args,
                const fs::path& log_dir, bool verbose) {
  throw_if_interrupted();
  fs::create_directories(log_dir);
  const fs::path log = log_dir / (step + ".log");
  std::vector<std::string> argv_s = {exe.string(), step};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);

  std::vector<std::string> env_s;
  for (char** e = environ; e && *e; ++e)
    if (std::strncmp(*e, "QT_QPA_PLATFORM=", 16) != 0) env_s.emplace_back(*e);
  env_s.emplace_back("QT_QPA_PLATFORM=offscreen");
  std::vector<char*> envp;
  for (auto& e : env_s) envp.push_back(e.data());
  envp.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (!verbose) posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, exe.c_str(), &actions, nullptr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) fail("colmap {}: cannot start {}: {}", step, exe.string(), std::strerror(rc));
  // Polled rather than blocking: the interrupt handler restarts system calls (SA_RESTART), and a
  // SIGTERM sent to this process alone does not reach the command, which is ended here (a Ctrl-C
  // reaches it through the terminal's process group already).
  int status = 0;
  bool ended = false;
  for (;;) {
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    if (done == pid) break;
    if (done < 0 && errno != EINTR)
      fail("colmap {}: waitpid failed: {}", step, std::strerror(errno));
    if (interrupt_signal() != 0 && !ended) {
      ::kill(pid, SIGTERM);
      ended = true;
    }
    std::this_thread::sleep_for(kWaitPoll);
  }
  throw_if_interrupted();
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return;
  const std::string how = WIFEXITED(status)
                              ? fmt::format("exit status {}", WEXITSTATUS(status))
                              : fmt::format("crashed with signal {}", WTERMSIG(status));
  const std::string line = verbose ? std::string("see stderr") : last_error_line(log);
  fail("colmap {} failed ({}){}: {} (log: {})", step, how, failure_reason(line), line,
       shown_path(log));
}

std::vector<std::string> sift_extraction_args(const ColmapOptions& options) {
  return {"--SiftExtraction.use_gpu",          "0",
          "--SiftExtraction.num_threads",      std::to_string(options.threads),
          "--SiftExtraction.max_image_size",   std::to_string(options.max_image_size),
          "--SiftExtraction.max_num_features", std::to_string(options.max_num_features),
          "--SiftExtraction.peak_threshold",   number(options.peak_threshold)};
}

std::vector<std::string> exhaustive_matching_args(const ColmapOptions& options) {
  return {"--SiftMatching.use_gpu",         "0",
          "--SiftMatching.num_threads",     std::to_string(options.threads),
          "--SiftMatching.guided_matching", options.guided_matching ? "1" : "0"};
}

std::string number(double v) {
  return fmt::format("{:.17g}", v);
}

WorkFolder::WorkFolder(std::string_view name)
    : path_(fs::temp_directory_path() / fmt::format("retimegs-colmap-{}-{}", ::getpid(), name)) {
  fs::remove_all(path_);
  fs::create_directories(path_);
}

WorkFolder::~WorkFolder() {
  std::error_code ignored;
  fs::remove_all(path_, ignored);
}

}  // namespace retimegs::colmap
