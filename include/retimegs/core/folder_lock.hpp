#pragma once
// A process-level lock on a folder: flock on FOLDER/.lock, held while the object lives. The kernel
// releases it when the process ends however it ends (kill -9 included), so a stale lock cannot
// outlive its holder.
#include <filesystem>
#include <string>

namespace retimegs {

class FolderLock {
 public:
  // Takes the lock on `folder` (which must exist) without waiting; throws Error naming the folder
  // and the holder's pid when another process holds it. `what` names the folder's use in the
  // message ("run folder").
  FolderLock(const std::filesystem::path& folder, const std::string& what);
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;
  ~FolderLock();

  // FOLDER/.lock.
  static std::filesystem::path file(const std::filesystem::path& folder);

 private:
  int fd_ = -1;
};

}  // namespace retimegs
