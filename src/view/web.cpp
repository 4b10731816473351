#include "retimegs/view/web.hpp"

#include <atomic>
#include <cerrno>
#include <chrono>
#include <fstream>
#include <thread>

#include <httplib.h>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/interrupt.hpp"

namespace retimegs::view {

std::vector<WebFile> web_files(const Packed& packed) {
  std::vector<WebFile> files = viewer_sources();
  files.push_back({"model.json", packed.manifest, "application/json"});
  files.push_back(
      {"model.bin",
       std::string_view(reinterpret_cast<const char*>(packed.data.data()), packed.data.size()),
       "application/octet-stream"});
  return files;
}

void write_web(const std::filesystem::path& out, const std::vector<WebFile>& files, bool force) {
  check_output_free(out, force);
  AtomicDirectory dir(out, force);
  for (const WebFile& f : files) {
    throw_if_interrupted();  // Ctrl-C: `dir` removes the unfinished folder
    const std::filesystem::path path = dir.temp_path() / f.path;
    std::filesystem::create_directories(path.parent_path());
    errno = 0;
    std::ofstream stream(path, std::ios::binary);
    stream.write(f.content.data(), std::streamsize(f.content.size()));
    stream.close();
    check_written(stream, path);
  }
  dir.commit();
}

void serve(const std::vector<WebFile>& files, const std::string& host, int port,
           const std::function<void(const std::string& url)>& on_listening) {
  httplib::Server server;
  // SO_REUSEADDR only: a restarted viewer rebinds its port at once, but a port that another
  // process listens on is refused (httplib's default SO_REUSEPORT would share it silently, and
  // the two servers would answer requests in turn, each with its own model).
  server.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  for (const WebFile& f : files) {
    const auto handler = [&f](const httplib::Request&, httplib::Response& response) {
      // The model changes between runs on one port: the browser must not keep an old one.
      response.set_header("Cache-Control", "no-store");
      response.set_content(f.content.data(), f.content.size(), f.content_type.c_str());
    };
    server.Get("/" + f.path, handler);
    if (f.path == "index.html") server.Get("/", handler);
  }
  const int bound = port == 0                         ? server.bind_to_any_port(host)
                    : server.bind_to_port(host, port) ? port
                                                      : -1;
  if (bound < 0)
    fail("view: cannot listen on {}:{} (in use, or not an address of this machine)", host, port);
  const std::string shown = host.find(':') != std::string::npos ? "[" + host + "]" : host;
  on_listening("http://" + shown + ":" + std::to_string(bound) + "/");
  // Ctrl-C and SIGTERM only record the signal (core/interrupt.hpp): a watcher stops the server on
  // one, and the command ends as any interrupted command does (exit 130 / 143).
  std::atomic<bool> done = false;
  std::thread watcher([&] {
    while (!done) {
      if (interrupt_signal()) {
        server.stop();
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  });
  const bool served = server.listen_after_bind();
  done = true;
  watcher.join();
  if (const int signal = interrupt_signal())
    throw Interrupted(signal, "view: stopped by " + signal_name(signal));
  if (!served) fail("view: the server on {}:{} stopped", host, bound);
}

}  // namespace retimegs::view
