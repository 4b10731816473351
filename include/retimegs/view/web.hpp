#pragma once
// The browser viewer as files: its sources (web/, embedded in the binary at build time so that
// `retimegs view` and `export --web` work from any install location) beside a model's data. The
// same files are served by serve() and written by write_web(), so a static host shows exactly
// what `retimegs view` shows.
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "retimegs/view/pack.hpp"

namespace retimegs::view {

struct WebFile {
  std::string path;          // relative, '/'-separated: "index.html", "model.bin"
  std::string_view content;  // bytes (owned by the embedded sources or by the Packed)
  std::string content_type;
};

// The viewer's own sources (index.html and its ES modules), as embedded at build time.
const std::vector<WebFile>& viewer_sources();

// viewer_sources() and the packed model as model.json and model.bin; `packed` must outlive them.
std::vector<WebFile> web_files(const Packed& packed);

// Writes `files` into the folder `out` atomically (all or nothing); an existing `out` is refused
// unless `force`.
void write_web(const std::filesystem::path& out, const std::vector<WebFile>& files, bool force);

// Serves `files` over HTTP on host:port (port 0: any free port) until Ctrl-C or SIGTERM, then
// throws Interrupted (core/interrupt.hpp). Calls
// `on_listening` with the viewer's URL once the socket is bound. Throws Error naming host and
// port when it cannot bind.
void serve(const std::vector<WebFile>& files, const std::string& host, int port,
           const std::function<void(const std::string& url)>& on_listening);

}  // namespace retimegs::view
