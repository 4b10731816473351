#include "retimegs/core/folder_lock.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

#include "retimegs/core/error.hpp"

namespace retimegs {
namespace fs = std::filesystem;

fs::path FolderLock::file(const fs::path& folder) {
  return folder / ".lock";
}

FolderLock::FolderLock(const fs::path& folder, const std::string& what) {
  const fs::path path = file(folder);
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) fail("{}: cannot open the {} lock: {}", path.string(), what, std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int error = errno;
    char buffer[32] = {};
    const ssize_t n = ::pread(fd_, buffer, sizeof buffer - 1, 0);
    ::close(fd_);
    fd_ = -1;
    if (error != EWOULDBLOCK)
      fail("{}: cannot lock the {}: {}", path.string(), what, std::strerror(error));
    std::string pid(buffer, n > 0 ? std::size_t(n) : 0);
    while (!pid.empty() && (pid.back() == '\n' || pid.back() == ' ')) pid.pop_back();
    fail("{}: the {} is in use by another process (pid {}); wait for it or stop it",
         folder.string(), what, pid.empty() ? "unknown" : pid);
  }
  // The holder's pid, for the message of the next process that finds the folder locked.
  const std::string pid = std::to_string(::getpid()) + "\n";
  if (::ftruncate(fd_, 0) != 0 || ::pwrite(fd_, pid.data(), pid.size(), 0) != ssize_t(pid.size()))
    fail("{}: cannot write the {} lock: {}", path.string(), what, std::strerror(errno));
}

FolderLock::~FolderLock() {
  if (fd_ >= 0) ::close(fd_);  // closing the last descriptor releases the flock
}

}  // namespace retimegs
