#include "retimegs/core/atomic_file.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <system_error>

#include "retimegs/core/error.hpp"

namespace retimegs {
namespace fs = std::filesystem;

namespace {
fs::path temp_sibling(const fs::path& final_path) {
  fs::path name = final_path.filename();
  // Keep the extension last so that writers choosing a codec by extension (OpenCV) still work.
  const std::string stem = name.stem().string(), ext = name.extension().string();
  return final_path.parent_path() / fmt::format(".{}.tmp{}{}", stem, ::getpid(), ext);
}

void ensure_parent(const fs::path& path) {
  const fs::path parent = path.parent_path();
  if (parent.empty()) return;
  std::error_code ec;
  fs::create_directories(parent, ec);
  if (ec) fail("{}: cannot create directory: {}", parent.string(), ec.message());
}
}  // namespace

fs::path output_path(fs::path path) {
  while (!path.has_filename() && path.has_relative_path()) path = path.parent_path();
  return path;
}

void check_output_free(const fs::path& path, bool force) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (!fs::exists(status)) return;
  if (!fs::is_regular_file(status) && !fs::is_directory(status))
    fail("{}: is a device, FIFO or socket, not a place to write an output", path.string());
  if (!force) fail("{}: output already exists (pass --force to replace it)", path.string());
}

namespace {
// `path` made absolute with its symbolic links, "." and ".." resolved (as far as it exists).
fs::path resolved(const fs::path& path) {
  std::error_code ec;
  fs::path p = fs::weakly_canonical(fs::absolute(output_path(path), ec), ec);
  if (ec) p = fs::absolute(output_path(path)).lexically_normal();
  return output_path(p);
}

// Whether `inner` is `outer` or lies below it (both resolved).
bool within(const fs::path& inner, const fs::path& outer) {
  auto i = inner.begin();
  for (auto o = outer.begin(); o != outer.end(); ++o, ++i)
    if (i == inner.end() || *i != *o) return false;
  return true;
}
}  // namespace

void check_output_overlap(const fs::path& output, const std::string& flag,
                          const std::vector<InputPath>& inputs) {
  const fs::path out = resolved(output);
  for (const InputPath& input : inputs) {
    if (input.path.empty()) continue;
    const fs::path in = resolved(input.path);
    if (out == in)
      fail("{} {}: is the {} {}; write the output elsewhere", flag, output.string(), input.what,
           input.path.string());
    if (within(in, out))
      fail("{} {}: holds the {} {}; replacing it would delete it", flag, output.string(),
           input.what, input.path.string());
    if (input.tree && within(out, in) && fs::exists(out))
      fail("{} {}: lies inside the {} {} and exists; replacing it would change the {}", flag,
           output.string(), input.what, input.path.string(), input.what);
  }
}

AtomicFile::AtomicFile(fs::path final_path)
    : final_(output_path(std::move(final_path))), temp_(temp_sibling(final_)) {
  ensure_parent(final_);
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    std::error_code ec;
    fs::remove(temp_, ec);
  }
}

void AtomicFile::commit() {
  std::error_code ec;
  fs::rename(temp_, final_, ec);
  if (ec) fail("{}: cannot move finished file into place: {}", final_.string(), ec.message());
  committed_ = true;
}

void write_text_file(const fs::path& path, std::string_view text) {
  AtomicFile file(path);
  {
    std::ofstream out(file.temp_path());
    errno = 0;
    out.write(text.data(), std::streamsize(text.size()));
    out.close();  // the last bytes reach the disk here: a full disk shows only now
    if (!out)
      fail("{}: write failed: {}", path.string(), errno ? std::strerror(errno) : "unknown error");
  }
  file.commit();
}

AtomicDirectory::AtomicDirectory(fs::path final_path, bool replace)
    : final_(output_path(std::move(final_path))), temp_(temp_sibling(final_)), replace_(replace) {
  check_output_free(final_, replace_);
  ensure_parent(final_);
  std::error_code ec;
  fs::remove_all(temp_, ec);
  fs::create_directories(temp_, ec);
  if (ec) fail("{}: cannot create directory: {}", temp_.string(), ec.message());
}

AtomicDirectory::~AtomicDirectory() {
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(temp_, ec);
  }
}

void AtomicDirectory::commit() {
  std::error_code ec;
  if (replace_ && fs::exists(final_)) fs::remove_all(final_, ec);
  if (ec) fail("{}: cannot remove the old output: {}", final_.string(), ec.message());
  fs::rename(temp_, final_, ec);
  if (ec) fail("{}: cannot move finished output into place: {}", final_.string(), ec.message());
  committed_ = true;
}

}  // namespace retimegs
