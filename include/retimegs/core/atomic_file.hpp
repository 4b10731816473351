#pragma once
// Outputs appear whole or not at all: write to a temporary sibling name, then rename.
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace retimegs {

// The path an output is written to: `out/` (trailing separators) names the entry `out`, whose
// temporary sibling must lie beside it, not inside it.
std::filesystem::path output_path(std::filesystem::path path);

// Throws Error naming `path` when it exists and `force` is not set: a command never overwrites an
// output unless told to (--force). A device, FIFO or socket is refused even with `force`: the
// rename of a finished output would replace the node itself.
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

// A file written through temp_path() becomes `final_path` on commit(); if the object is destroyed
// before commit() (an error was thrown), the temporary file is removed.
class AtomicFile {
 public:
  explicit AtomicFile(std::filesystem::path final_path);
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  ~AtomicFile();

  const std::filesystem::path& temp_path() const { return temp_; }
  const std::filesystem::path& final_path() const { return final_; }
  void commit();

 private:
  std::filesystem::path final_, temp_;
  bool committed_ = false;
};

// Writes `text` to `path` through an AtomicFile, checking the stream: throws Error naming `path`
// when it cannot be written whole (nothing appears at `path` then).
void write_text_file(const std::filesystem::path& path, std::string_view text);

// The same for a whole directory tree (a scene, a folder of renders). `final_path` must not exist
// unless `replace` is set, in which case the old tree is removed at commit time.
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
