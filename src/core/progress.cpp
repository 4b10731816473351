#include "retimegs/core/progress.hpp"

#include <unistd.h>

#include <cstdio>

#include <fmt/format.h>

#include "retimegs/core/interrupt.hpp"

namespace retimegs {

namespace {
std::string format_seconds(double s) {
  if (!(s >= 0) || s > 1e7) return "--:--";
  const long total = long(s + 0.5);
  if (total >= 3600)
    return fmt::format("{}:{:02}:{:02}", total / 3600, total / 60 % 60, total % 60);
  return fmt::format("{:02}:{:02}", total / 60, total % 60);
}
}  // namespace

Progress::Progress(std::string label, std::size_t total, bool enabled, bool interruptible)
    : label_(std::move(label)),
      total_(total),
      enabled_(enabled),
      interruptible_(interruptible),
      tty_(::isatty(STDERR_FILENO) != 0),
      stream_(tty_ ? stderr : stdout),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {}

Progress::~Progress() {
  finish();
}

void Progress::tick(std::size_t n, const std::string& status) {
  if (interruptible_) throw_if_interrupted();
  std::lock_guard lock(mutex_);
  done_ += n;
  if (!status.empty()) status_ = status;
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (tty_) {
    if (now - last_draw_ > std::chrono::milliseconds(100) || done_ >= total_) {
      last_draw_ = now;
      draw(false);
    }
  } else {
    const int decile = total_ ? int(10 * done_ / total_) : 10;
    if (decile != last_decile_) {
      last_decile_ = decile;
      draw(false);
    }
  }
}

void Progress::finish() {
  std::lock_guard lock(mutex_);
  if (finished_ || !enabled_) return;
  finished_ = true;
  if (tty_) draw(true);
}

void Progress::draw(bool final_line) {
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double fraction = total_ ? double(done_) / double(total_) : 1.0;
  const double eta = done_ ? elapsed * (double(total_) - double(done_)) / double(done_) : -1;
  std::string line;
  if (tty_) {
    constexpr int kWidth = 28;
    const int filled = int(fraction * kWidth);
    line = fmt::format("\r{} [{}{}] {}/{} {:3.0f}% {} elapsed {} eta {}\x1b[K", label_,
                       std::string(filled, '#'), std::string(kWidth - filled, '.'), done_, total_,
                       100 * fraction, status_, format_seconds(elapsed), format_seconds(eta));
    if (final_line) line += "\n";
  } else {
    line = fmt::format("{} {}/{} ({:.0f}%) {} elapsed {} eta {}\n", label_, done_, total_,
                       100 * fraction, status_, format_seconds(elapsed), format_seconds(eta));
  }
  std::fputs(line.c_str(), stream_);
  std::fflush(stream_);
}

}  // namespace retimegs
