#pragma once
// Reading a JSON file with the project's errors: every JSON input (scene.json, checkpoints,
// importers' metadata) fails the same way, naming the file.
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

namespace retimegs::io {

// The parsed contents of `path`. Throws Error "<path>: cannot open <what>" when it cannot be
// opened, "<path>: not a regular file" for a FIFO, device or folder, and "<path>: malformed JSON:
// <parser message>" when it does not parse.
nlohmann::json read_json_file(const std::filesystem::path& path, const std::string& what);

}  // namespace retimegs::io
