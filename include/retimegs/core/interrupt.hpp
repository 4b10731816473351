#pragma once
// Ctrl-C (SIGINT) and SIGTERM. The handler only records the signal; long loops poll it and stop
// between two units of work, so that outputs are never left half-written: most commands throw
// Interrupted (their temporary outputs are removed as the stack unwinds), `train` first writes a
// checkpoint. A second signal while the first is being handled ends the process at once.
#include <cstddef>
#include <exception>
#include <string>

namespace retimegs {

// Thrown by a loop that stopped on a signal; apps print what() in one line and exit with
// exit_code(): 128 + the signal (130 for SIGINT, 143 for SIGTERM), the shell's convention.
class Interrupted : public std::exception {
 public:
  Interrupted(int signal, std::string message);
  const char* what() const noexcept override { return message_.c_str(); }
  int signal() const { return signal_; }
  int exit_code() const { return 128 + signal_; }

 private:
  int signal_;
  std::string message_;
};

// Installs the SIGINT and SIGTERM handlers and ignores SIGXFSZ, so that a write past the
// file-size limit fails like one on a full disk (once, at program start).
void install_interrupt_handlers();

// The signal received since start (SIGINT or SIGTERM), or 0.
int interrupt_signal();

// "SIGINT", "SIGTERM".
std::string signal_name(int signal);

// Throws Interrupted ("interrupted by SIGINT; unfinished outputs removed") when a signal has
// arrived. Called between units of work, outside OpenMP regions (parallel_for's bodies may call it:
// it carries exceptions out of its loop).
void throw_if_interrupted();

// Loops over many small items (primitives, rows, bytes) poll once every kItemsPerInterruptPoll
// items: often enough that a signal stops a pass over a million primitives within milliseconds,
// rarely enough to cost nothing beside the work.
constexpr std::size_t kItemsPerInterruptPoll = std::size_t(1) << 16;

// throw_if_interrupted() at every kItemsPerInterruptPoll-th item `i` of a loop.
inline void throw_if_interrupted_every(std::size_t i) {
  if (i % kItemsPerInterruptPoll == 0) throw_if_interrupted();
}

// Test hook: forget a received signal.
void clear_interrupt();

}  // namespace retimegs
