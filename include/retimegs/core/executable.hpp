#pragma once
// Programs the commands run (COLMAP, ffmpeg): looked up on PATH as a shell would, so that a
// missing one is named before any work starts.
#include <filesystem>
#include <string>

namespace retimegs {

// `name` itself when it contains a '/', else the first runnable file `name` in a folder of PATH
// (/usr/local/bin:/usr/bin:/bin when PATH is unset); empty when there is none.
std::filesystem::path find_executable(const std::string& name);

}  // namespace retimegs
