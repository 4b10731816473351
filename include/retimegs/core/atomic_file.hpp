#pragma once
// Outputs appear whole or not at all: write to a temporary sibling name, then rename. An output a
// user named without --force is moved into place only if nothing is there yet (renameat2
// RENAME_NOREPLACE): of two writers of one output, the one that finishes second is refused.
#include <filesystem>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

namespace retimegs {

// The path an output is written to: `out/` (trailing separators) names the entry `out`, whose
// temporary sibling must lie beside it, not inside it.
std::filesystem::path output_path(std::filesystem::path path);

// Throws Error naming `path` when it exists and `force` is not set: a command never overwrites an
// output unless told to (--force). A symbolic link counts as an output, dangling or a loop too. A
// device, FIFO or socket is refused even with `force`: the rename of a finished output would
// replace the node itself.
void check_output_free(const std::filesystem::path& path, bool force);

// An input of a command: a file, or a folder whose whole tree the command reads (`tree`).
struct InputPath {
  std::filesystem::path path;
  std::string what;  // "model", "scene", "source folder"
  bool tree = false;
};

// Throws Error naming `flag`, the output and the input when writing `output` could overwrite or
// delete an input, whatever --force says: `output` resolves (symbolic links, "..", "./") to the
// input, to a folder holding it, or to an existing entry inside an input tree.
void check_output_overlap(const std::filesystem::path& output, const std::string& flag,
                          const std::vector<InputPath>& inputs);

// `path` as the user named it: a temporary sibling of this process (".x.tmp<pid>.png", a file or
// a folder on the way) is shown as the output it becomes ("x.png"), for error messages.
std::string shown_path(const std::filesystem::path& path);

// Throws Error "<shown_path(path)>: write failed: <the system's reason>" when `out` has failed.
// Call it right after the operation that may fail (close() for the last bytes), so that errno is
// that operation's; set errno to 0 before the writes.
void check_written(const std::ostream& out, const std::filesystem::path& path);

// A file written through temp_path() becomes `final_path` on commit(); if the object is destroyed
// before commit() (an error was thrown), the temporary file is removed. With `replace` (a file the
// command owns, or --force) commit() replaces what is at `final_path`; without it, it throws Error
// naming the output when anything is there (another writer's output), replacing nothing.
class AtomicFile {
 public:
  explicit AtomicFile(std::filesystem::path final_path, bool replace = true);
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  ~AtomicFile();

  const std::filesystem::path& temp_path() const { return temp_; }
  const std::filesystem::path& final_path() const { return final_; }
  void commit();

 private:
  std::filesystem::path final_, temp_;
  bool replace_ = false, committed_ = false;
};

// Writes `text` to `path` through an AtomicFile(path, replace), checking the stream: throws Error
// naming `path` when it cannot be written whole (nothing appears at `path` then).
void write_text_file(const std::filesystem::path& path, std::string_view text, bool replace = true);

// The same for a whole directory tree (a scene, a folder of renders). `final_path` must not exist
// unless `replace` is set, in which case the old tree is removed at commit time; without
// `replace`, an entry that another writer created meanwhile is refused at commit time.
class AtomicDirectory {
 public:
  explicit AtomicDirectory(std::filesystem::path final_path, bool replace = false);
  AtomicDirectory(const AtomicDirectory&) = delete;
  AtomicDirectory& operator=(const AtomicDirectory&) = delete;
  ~AtomicDirectory();

  const std::filesystem::path& temp_path() const { return temp_; }
  const std::filesystem::path& final_path() const { return final_; }
  void commit();

 private:
  std::filesystem::path final_, temp_;
  bool replace_ = false, committed_ = false;
};

}  // namespace retimegs
