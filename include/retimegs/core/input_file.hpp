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

// The whole of text file `path` (check_input_file first); throws Error "<path>: cannot open
// <what>" otherwise.
std::string read_text_file(const std::filesystem::path& path, const std::string& what);

}  // namespace retimegs
