#include "retimegs/core/interrupt.hpp"

#include <csignal>

#include <atomic>

#include <fmt/format.h>

namespace retimegs {

namespace {

// Lock-free, so that the handler may touch it (async-signal-safe).
std::atomic<int> g_signal{0};
static_assert(std::atomic<int>::is_always_lock_free);

extern "C" void on_signal(int signal) {
  int expected = 0;
  if (!g_signal.compare_exchange_strong(expected, signal)) {
    // The second signal: the user wants out now. The default action ends the process with the
    // signal's status; whatever temporary file was being written is removed at the next start
    // (train) or stays as a hidden ".<name>.tmp<pid>" sibling.
    std::signal(signal, SIG_DFL);
    std::raise(signal);
  }
}

}  // namespace

Interrupted::Interrupted(int signal, std::string message)
    : signal_(signal), message_(std::move(message)) {}

void install_interrupt_handlers() {
  struct sigaction action = {};
  action.sa_handler = on_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;  // blocking reads and writes resume; the loops poll the flag
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  // A write past the file-size limit (ulimit -f) then fails with EFBIG, as one on a full disk
  // fails with ENOSPC, through the writers' error path (one line naming the output, temporaries
  // removed) instead of SIGXFSZ's default action, which kills the process without a word.
  std::signal(SIGXFSZ, SIG_IGN);
}

int interrupt_signal() {
  return g_signal.load();
}

std::string signal_name(int signal) {
  if (signal == SIGINT) return "SIGINT";
  if (signal == SIGTERM) return "SIGTERM";
  return fmt::format("signal {}", signal);
}

void throw_if_interrupted() {
  if (const int s = g_signal.load())
    throw Interrupted(s,
                      fmt::format("interrupted by {}; unfinished outputs removed", signal_name(s)));
}

void clear_interrupt() {
  g_signal.store(0);
}

}  // namespace retimegs
