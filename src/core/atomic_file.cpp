#include "retimegs/core/atomic_file.hpp"

#include <fcntl.h>  // renameat2
#include <stdio.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <system_error>

#include "retimegs/core/error.hpp"

namespace retimegs {
namespace fs = std::filesystem;

namespace {
// The temporary sibling ".<stem>.tmp<pid><ext>" of an output; shown_path undoes it.
fs::path temp_sibling(const fs::path& final_path) {
  fs::path name = final_path.filename();
  // Keep the extension last so that writers choosing a codec by extension (OpenCV) still work.
  const std::string stem = name.stem().string(), ext = name.extension().string();
  return final_path.parent_path() / fmt::format(".{}.tmp{}{}", stem, ::getpid(), ext);
}

bool exists_or_link(const fs::path& path) {
  std::error_code ec;
  return fs::exists(fs::symlink_status(path, ec));
}

// Moves the finished `from` to `to`. With `replace` whatever is at `to` is replaced; without, an
// entry there (a file, a folder, a link, even a dangling one) is left alone and false returned:
// of two writers of one output, the one that finishes second is refused instead of silently
// replacing the first one's output.
bool move_into_place(const fs::path& from, const fs::path& to, bool replace) {
  if (::renameat2(AT_FDCWD, from.c_str(), AT_FDCWD, to.c_str(), replace ? 0 : RENAME_NOREPLACE) ==
      0)
    return true;
  if (!replace && errno == EEXIST) return false;
  if (!replace && (errno == EINVAL || errno == ENOSYS)) {
    // A file system without RENAME_NOREPLACE (some network ones): checked, then renamed.
    if (exists_or_link(to)) return false;
    if (::rename(from.c_str(), to.c_str()) == 0) return true;
  }
  fail("{}: cannot move the finished output into place: {}", to.string(), std::strerror(errno));
}

[[noreturn]] void fail_taken(const fs::path& path) {
  fail(
      "{}: output already exists: another writer created it while this one ran (nothing was "
      "replaced; pass --force to replace it)",
      path.string());
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

std::string shown_path(const fs::path& path) {
  const std::string marker = fmt::format(".tmp{}", ::getpid());
  fs::path shown;
  for (const fs::path& part : path) {
    std::string name = part.string();
    // A temporary of a temporary (a file written whole into another writer's temporary name, as
    // FrameWriter pairs a frame with its depth pass) is undone to the output as well.
    for (;;) {
      const std::size_t at = name.find(marker);
      if (!(name.size() > 1 && name[0] == '.' && at != std::string::npos && at > 1)) break;
      name = name.substr(1, at - 1) + name.substr(at + marker.size());
    }
    shown /= name;
  }
  return shown.string();
}

void check_output_free(const fs::path& path, bool force) {
  // A link counts as an output whatever it points to: a dangling one or a loop too.
  if (!exists_or_link(path)) return;
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (fs::exists(status) && !fs::is_regular_file(status) && !fs::is_directory(status))
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

AtomicFile::AtomicFile(fs::path final_path, bool replace)
    : final_(output_path(std::move(final_path))), temp_(temp_sibling(final_)), replace_(replace) {
  ensure_parent(final_);
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    std::error_code ec;
    fs::remove(temp_, ec);
  }
}

void AtomicFile::commit() {
  if (!move_into_place(temp_, final_, replace_)) fail_taken(final_);
  committed_ = true;
}

void check_written(const std::ostream& out, const fs::path& path) {
  if (!out)
    fail("{}: write failed: {}", shown_path(path),
         errno ? std::strerror(errno) : "the stream failed without a system error");
}

void write_text_file(const fs::path& path, std::string_view text, bool replace) {
  AtomicFile file(path, replace);
  {
    errno = 0;
    std::ofstream out(file.temp_path(), std::ios::binary);
    out.write(text.data(), std::streamsize(text.size()));
    out.close();  // the last bytes reach the disk here: a full disk shows only now
    check_written(out, path);
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
  if (ec) fail("{}: cannot create directory: {}", final_.string(), ec.message());
}

AtomicDirectory::~AtomicDirectory() {
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(temp_, ec);
  }
}

void AtomicDirectory::commit() {
  std::error_code ec;
  if (replace_ && exists_or_link(final_)) {
    fs::remove_all(final_, ec);  // a link is removed, not what it points to
    if (ec) fail("{}: cannot remove the old output: {}", final_.string(), ec.message());
  }
  if (!move_into_place(temp_, final_, /*replace=*/false)) fail_taken(final_);
  committed_ = true;
}

}  // namespace retimegs
