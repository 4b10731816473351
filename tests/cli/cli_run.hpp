#pragma once
// Running the retimegs binary from the CLI tests beyond test::run_cli: under a time limit (a hang
// fails instead of blocking the suite), as a child process the test can signal, and a snapshot of
// a folder tree to prove that a command left nothing behind and damaged nothing.
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "test_util.hpp"

namespace retimegs::test {

struct TimedResult {
  int status = -1;  // exit status; 124 when the time limit killed it
  std::string err;  // stderr
};

// `retimegs ARGS` through the shell under `timeout`, stdout discarded; `shell_prefix` runs first
// in the same shell (e.g. "ulimit -f 1; ").
inline TimedResult run_cli_timed(const std::string& args, int seconds = 60,
                                 const std::string& shell_prefix = "") {
  TempDir scratch;
  const auto err_file = scratch / "stderr.txt";
  const std::string command = shell_prefix + "timeout " + std::to_string(seconds) + " " +
                              std::string(RETIMEGS_BINARY) + " " + args + " >/dev/null 2>" +
                              err_file.string() + " </dev/null";
  const int raw = std::system(command.c_str());
  TimedResult result;
  result.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  result.err = read_text(err_file);
  return result;
}

// Whether `err` is exactly one line, "retimegs: ...\n".
inline bool is_single_error_line(const std::string& err) {
  return err.rfind("retimegs: ", 0) == 0 && !err.empty() && err.back() == '\n' &&
         err.find('\n') == err.size() - 1;
}

// The last line of `err`, without its line break.
inline std::string last_line(const std::string& err) {
  const std::size_t end = err.find_last_not_of('\n');
  if (end == std::string::npos) return {};
  const std::size_t start = err.rfind('\n', end);
  return err.substr(start == std::string::npos ? 0 : start + 1, end - start);
}

// A retimegs process started in the background: stderr to `err_file`, stdout (the log and, stderr
// not being a terminal, the progress lines) to `err_file` + ".stdout".
class CliProcess {
 public:
  CliProcess(const std::vector<std::string>& args, std::filesystem::path err_file)
      : err_file_(std::move(err_file)), out_file_(err_file_.string() + ".stdout") {
    std::vector<std::string> argv_strings = {RETIMEGS_BINARY};
    argv_strings.insert(argv_strings.end(), args.begin(), args.end());
    pid_ = ::fork();
    if (pid_ == 0) {
      const int err = ::open(err_file_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      const int out = ::open(out_file_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      const int null = ::open("/dev/null", O_RDONLY);
      ::dup2(err, 2), ::dup2(out, 1), ::dup2(null, 0);
      std::vector<char*> argv;
      for (std::string& s : argv_strings) argv.push_back(s.data());
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
  }
  CliProcess(const CliProcess&) = delete;
  CliProcess& operator=(const CliProcess&) = delete;
  ~CliProcess() {
    if (pid_ > 0 && !waited_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }

  pid_t pid() const { return pid_; }
  std::string err() const { return read_text(err_file_); }
  std::string out() const { return read_text(out_file_); }
  void signal(int s) const { ::kill(pid_, s); }

  // Waits until `ready(stderr so far)` holds or the process ends; false after `seconds`.
  bool wait_for_err(const std::function<bool(const std::string&)>& ready, double seconds) const {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end) {
      if (ready(err())) return true;
      siginfo_t info = {};
      if (::waitid(P_PID, id_t(pid_), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid != 0)
        return ready(err());  // it ended
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return false;
  }

  // The exit status (128 + the signal when a signal ended it).
  int wait() {
    int raw = 0;
    ::waitpid(pid_, &raw, 0);
    waited_ = true;
    return WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
  }

 private:
  std::filesystem::path err_file_, out_file_;
  pid_t pid_ = -1;
  bool waited_ = false;
};

// Every entry under `root` with its kind and, for regular files, its contents; the run folders'
// lock files (core/folder_lock.hpp) are left out: taking a lock writes the holder's pid.
inline std::map<std::string, std::string> snapshot(const std::filesystem::path& root) {
  namespace fs = std::filesystem;
  std::map<std::string, std::string> entries;
  for (auto it = fs::recursive_directory_iterator(root); it != fs::recursive_directory_iterator();
       ++it) {
    const fs::file_status s = it->symlink_status();
    std::string value;
    if (it->path().filename() == ".lock") continue;
    if (fs::is_symlink(s))
      value = "link:" + fs::read_symlink(it->path()).string();
    else if (fs::is_regular_file(s))
      value = "file:" + read_text(it->path());
    else if (fs::is_directory(s))
      value = "dir";
    else
      value = "other";
    entries[fs::relative(it->path(), root).string()] = value;
  }
  return entries;
}

// The differences between two snapshots, one line each ("added x", "changed y", "removed z").
inline std::string snapshot_diff(const std::map<std::string, std::string>& before,
                                 const std::map<std::string, std::string>& after) {
  std::string diff;
  for (const auto& [path, value] : after) {
    const auto it = before.find(path);
    if (it == before.end())
      diff += "added " + path + "\n";
    else if (it->second != value)
      diff += "changed " + path + "\n";
  }
  for (const auto& [path, value] : before)
    if (!after.count(path)) diff += "removed " + path + "\n";
  return diff;
}

}  // namespace retimegs::test
