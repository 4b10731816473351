#pragma once
// A progress bar on stderr: an updating bar with rate and ETA on a terminal. When stderr is not a
// terminal, plain lines (every 10 %) on stdout, beside the log's info lines: there a script reads
// stderr as the error, and a failing command's stderr must hold its one error line alone.
// Thread-safe tick().
//
// tick() is also where the long loops of the commands notice Ctrl-C / SIGTERM: unless the bar
// was made with `interruptible` off (a loop that handles the signal itself, such as training's),
// it throws Interrupted once a signal has arrived (core/interrupt.hpp).
#include <chrono>
#include <cstddef>
#include <cstdio>
#include <mutex>
#include <string>

namespace retimegs {

class Progress {
 public:
  Progress(std::string label, std::size_t total, bool enabled = true, bool interruptible = true);
  ~Progress();
  // Advances by n steps; `status` is shown after the counts (e.g. "loss 0.031 psnr 27.4").
  void tick(std::size_t n = 1, const std::string& status = {});
  void finish();

 private:
  void draw(bool final_line);

  std::string label_, status_;
  std::size_t total_, done_ = 0;
  int last_decile_ = -1;
  bool enabled_, interruptible_, tty_, finished_ = false;
  std::FILE* stream_;  // stderr on a terminal, else stdout
  std::chrono::steady_clock::time_point start_, last_draw_;
  std::mutex mutex_;
};

}  // namespace retimegs
