// H.264 through the ffmpeg program (ffmpeg_video.hpp).
#include "retimegs/media/ffmpeg_video.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "retimegs/core/error.hpp"
#include "retimegs/core/executable.hpp"
#include "retimegs/core/interrupt.hpp"

extern char** environ;

namespace retimegs::media {
namespace fs = std::filesystem;

namespace {

// How often a finishing ffmpeg is checked for its end and for a signal: unnoticeable beside the
// encoder's flush of its look-ahead frames.
constexpr std::chrono::milliseconds kWaitPoll{5};

// The longest piece of ffmpeg's log quoted in a message; the log itself holds the rest.
constexpr std::size_t kMaxQuoted = 240;

// ffmpeg's muxer for an output's extension (FrameWriter's H.264 containers).
const char* muxer(const fs::path& out) {
  const std::string ext = out.extension().string();
  if (ext == ".mov") return "mov";
  if (ext == ".mkv") return "matroska";
  return "mp4";
}

// The line of ffmpeg's log that says why it failed: the first one (at -loglevel error the log
// holds errors alone, and later lines are their consequences: "Conversion failed!"), with the
// temporary `file` shown as the output `out`; empty when the log is.
std::string first_error(const fs::path& log, const fs::path& file, const fs::path& out) {
  std::ifstream in(log);
  std::string line;
  while (std::getline(in, line)) {
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
    if (line.empty()) continue;
    for (std::size_t at; (at = line.find(file.string())) != std::string::npos;)
      line.replace(at, file.string().size(), out.string());
    if (line.size() > kMaxQuoted) line = line.substr(0, kMaxQuoted) + "...";
    return line;
  }
  return {};
}

// A new, empty log file in the temporary folder, readable by its owner alone, and its descriptor
// (closed on exec: ffmpeg gets it as its stdout and stderr only). Created exclusively under a
// random name (mkostemps), never opened through a link another user left in a shared /tmp.
std::pair<fs::path, int> new_log(const fs::path& out) {
  std::string name = (fs::temp_directory_path() / "retimegs-ffmpeg-XXXXXX.log").string();
  const int fd = ::mkostemps(name.data(), 4, O_CLOEXEC);
  if (fd < 0)
    fail("{}: cannot start ffmpeg: cannot create its log {}: {}", out.string(), name,
         std::strerror(errno));
  return {name, fd};
}

}  // namespace

fs::path find_ffmpeg(const fs::path& out) {
  fs::path exe = find_executable("ffmpeg");
  if (exe.empty())
    fail(
        "{}: H.264 video (.mp4, .mov, .mkv) is written by the ffmpeg program, which is not on "
        "PATH: install it (Debian package ffmpeg; scripts/setup.sh does), or write PNGs (--out a "
        "folder/)",
        out.string());
  return exe;
}

FfmpegVideo::FfmpegVideo(const fs::path& ffmpeg, const fs::path& file, const fs::path& out,
                         int width, int height, double fps, int crf, std::function<void()> explain)
    : out_(out), file_(file), explain_(std::move(explain)), width_(width), height_(height) {
  const auto [log, log_fd] = new_log(out);
  log_ = log;
  // A socket rather than a pipe: send() with MSG_NOSIGNAL reports a stopped ffmpeg as EPIPE,
  // where write() into a pipe would raise SIGPIPE and end this process without a word. Both ends
  // close on exec, so that no other child holds ffmpeg's input open (it would never see its end).
  int sockets[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sockets) != 0) {
    const int error = errno;
    ::close(log_fd);
    fs::remove(log_);
    fail("{}: cannot start ffmpeg: socketpair: {}", out_.string(), std::strerror(error));
  }
  const std::vector<std::string> args = {
      ffmpeg.string(), "-hide_banner", "-nostdin", "-nostats", "-loglevel", "error",
      // The input: raw frames on standard input.
      "-f", "rawvideo", "-pix_fmt", "rgb24", "-video_size", fmt::format("{}x{}", width, height),
      "-framerate", fmt::format("{:.17g}", fps), "-i", "-",
      // The output: what OpenCV's writer gave (High profile, 4:2:0), at the asked quality.
      "-c:v", "libx264", "-crf", std::to_string(crf), "-pix_fmt", "yuv420p", "-f", muxer(out), "-y",
      file.string()};
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, sockets[1], 0);
  posix_spawn_file_actions_adddup2(&actions, log_fd, 1);
  posix_spawn_file_actions_adddup2(&actions, log_fd, 2);
  // Its own process group: a Ctrl-C at the terminal reaches this process alone, which ends
  // ffmpeg itself (the destructor) rather than letting it complete a file that is then removed.
  // Its signal mask is cleared (a caller's blocked signals are not ffmpeg's); signals ignored
  // here stay ignored there, SIGXFSZ included, so that a file-size limit fails its write (EFBIG)
  // as it fails ours.
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  sigset_t none;
  sigemptyset(&none);
  posix_spawnattr_setsigmask(&attributes, &none);
  posix_spawnattr_setpgroup(&attributes, 0);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGMASK);
  const int rc = ::posix_spawn(&pid_, ffmpeg.c_str(), &actions, &attributes, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attributes);
  ::close(sockets[1]);
  ::close(log_fd);
  if (rc != 0) {
    ::close(sockets[0]);
    pid_ = -1;
    std::error_code ignored;
    fs::remove(log_, ignored);
    fail("{}: cannot start {}: {}; write PNGs (--out a folder/) to go on without it", out_.string(),
         ffmpeg.string(), std::strerror(rc));
  }
  input_ = sockets[0];
}

FfmpegVideo::~FfmpegVideo() {
  if (input_ >= 0) ::close(input_);
  if (pid_ > 0) {
    // SIGKILL: what it wrote is removed anyway, and a killed process cannot linger finishing it.
    ::kill(pid_, SIGKILL);
    while (::waitpid(pid_, nullptr, 0) < 0 && errno == EINTR) {
    }
  }
  if (!keep_log_) {
    std::error_code ignored;
    fs::remove(log_, ignored);
  }
}

void FfmpegVideo::write(const std::uint8_t* rgb) {
  const auto* at = reinterpret_cast<const char*>(rgb);
  std::size_t left = std::size_t(width_) * std::size_t(height_) * 3;
  while (left > 0) {
    const ssize_t sent = ::send(input_, at, left, MSG_NOSIGNAL);
    if (sent < 0) {
      if (errno == EINTR) continue;
      if (errno == EPIPE || errno == ECONNRESET) fail_stopped();  // ffmpeg exited
      fail("{}: cannot send a frame to ffmpeg: {}", out_.string(), std::strerror(errno));
    }
    at += sent;
    left -= std::size_t(sent);
  }
}

void FfmpegVideo::finish() {
  ::close(input_);  // the end of the input: ffmpeg encodes what it holds and writes the trailer
  input_ = -1;
  wait_for_exit();
  // ffmpeg (5.1) exits with status 0 when writing the trailer or closing the file fails, having
  // said so: at -loglevel error, any line in its log is a failure.
  if (!WIFEXITED(status_) || WEXITSTATUS(status_) != 0 || !first_error(log_, file_, out_).empty())
    fail_stopped();
  std::error_code ignored;
  fs::remove(log_, ignored);
}

void FfmpegVideo::wait_for_exit() {
  // Polled rather than blocking: the interrupt handler restarts system calls (SA_RESTART), so a
  // blocking waitpid would not return on Ctrl-C; throwing Interrupted here lets the destructor
  // end ffmpeg.
  while (pid_ > 0) {
    const pid_t done = ::waitpid(pid_, &status_, WNOHANG);
    if (done == pid_) {
      pid_ = -1;
      return;
    }
    if (done < 0 && errno != EINTR)
      fail("{}: waiting for ffmpeg: {}", out_.string(), std::strerror(errno));
    throw_if_interrupted();
    std::this_thread::sleep_for(kWaitPoll);
  }
}

void FfmpegVideo::fail_stopped() {
  if (input_ >= 0) ::close(input_);
  input_ = -1;
  wait_for_exit();
  const std::string how = WIFEXITED(status_)
                              ? fmt::format("exit status {}{}", WEXITSTATUS(status_),
                                            WEXITSTATUS(status_) == 0 ? ", after an error" : "")
                              : fmt::format("ended by signal {}, {}", WTERMSIG(status_),
                                            ::strsignal(WTERMSIG(status_)));
  if (explain_) explain_();
  keep_log_ = true;
  const std::string error = first_error(log_, file_, out_);
  if (WIFEXITED(status_) && WEXITSTATUS(status_) == 0 && error.empty())
    fail("{}: ffmpeg stopped reading frames before the last one (its log: {})", out_.string(),
         log_.string());
  fail("{}: ffmpeg failed ({}): {} (its log: {}); write PNGs (--out a folder/) to go on without it",
       out_.string(), how, error.empty() ? "(no output)" : error, log_.string());
}

}  // namespace retimegs::media
