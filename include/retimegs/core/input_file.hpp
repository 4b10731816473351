#pragma once
// Inputs are regular files: a FIFO would block the command forever, a device never end, and a
// folder fail with an unrelated message. One rule, applied where an input is opened.
#include <filesystem>
#include <string>

namespace retimegs {

// Throws Error "<path>: not a regular file (a FIFO; cannot read <what> from it)" when `path`
// exists and is not a regular file (symbolic links are followed). A missing file passes: its
// reader names it.
void check_input_file(const std::filesystem::path& path, const std::string& what);

// The status of `path` (symbolic links followed): file_type::not_found when nothing is there. A
// path the system cannot look up (a name longer than the file system allows, a loop of links, a
// folder without permission) throws Error naming it and the reason, where std::filesystem's own
// queries throw filesystem_error. For paths read from metadata files (image names in a Panoptic,
// nerfstudio or COLMAP model), which can be anything.
std::filesystem::file_status input_status(const std::filesystem::path& path);

// The whole of file `path`, text or binary (check_input_file first); throws Error "<path>: cannot
// open <what>" otherwise, and Interrupted on Ctrl-C / SIGTERM while it reads.
std::string read_text_file(const std::filesystem::path& path, const std::string& what);

}  // namespace retimegs
