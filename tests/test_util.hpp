#pragma once
// Shared helpers for the test suites: the reference data folder, scratch folders, running the CLI.
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <random>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "retimegs/core/camera.hpp"
#include "retimegs/core/error.hpp"

namespace retimegs::test {

inline std::filesystem::path shared_data() {
  return RETIMEGS_SHARED_DATA;
}

// Skips the current test when a reference data folder is missing (e.g. no ../shared beside the
// checkout); CI always has it.
#define RETIMEGS_REQUIRE_DATA(rel)                                                             \
  do {                                                                                         \
    if (!std::filesystem::exists(::retimegs::test::shared_data() / (rel)))                     \
      GTEST_SKIP() << "reference data missing: " << (::retimegs::test::shared_data() / (rel)); \
  } while (0)

// A fresh scratch folder removed at the end of the test.
class TempDir {
 public:
  TempDir() {
    std::random_device rd;
    path_ = std::filesystem::temp_directory_path() /
            ("retimegs-test-" + std::to_string(rd()) + std::to_string(rd()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Whether COLMAP (the Debian package colmap) is on PATH; its tests skip without it.
inline bool have_colmap() {
  return std::system("command -v colmap >/dev/null 2>&1") == 0;
}

struct CommandResult {
  int status = -1;
  std::string out, err;  // stdout, stderr
};

// Runs the retimegs binary with `args` (after `launcher`, a shell command such as `env -u X`, where
// given); captures stdout, stderr and the exit status.
inline CommandResult run_cli(const std::string& args, const std::string& launcher = "") {
  TempDir scratch;
  const auto out_file = scratch / "stdout.txt", err_file = scratch / "stderr.txt";
  const std::string command = launcher + (launcher.empty() ? "" : " ") + RETIMEGS_BINARY + " " +
                              args + " >" + out_file.string() + " 2>" + err_file.string();
  const int raw = std::system(command.c_str());
  CommandResult result;
  result.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  result.out = read_text(out_file);
  result.err = read_text(err_file);
  return result;
}

// Whether a refused command's stderr is one error line ("retimegs: ..."), possibly after progress
// lines: an import that works on several images at once may finish one (and report it) before
// another one fails.
inline bool is_one_error_line(const std::string& err) {
  std::istringstream lines(err);
  std::string line, last;
  int errors = 0;
  while (std::getline(lines, line)) {
    errors += line.rfind("retimegs: ", 0) == 0;
    last = line;
  }
  return errors == 1 && last.rfind("retimegs: ", 0) == 0 && err.back() == '\n';
}

// `retimegs import FORMAT --in dir/src --out dir/out ARGS` must be refused: exit status 2, one line
// naming every fragment, no dir/out and no temporary "*.out*" left in dir.
inline void expect_import_refused(const std::string& format, const std::filesystem::path& dir,
                                  std::initializer_list<std::string> fragments,
                                  const std::string& args = "") {
  const auto r = run_cli("import " + format + " --in " + (dir / "src").string() + " --out " +
                         (dir / "out").string() + args);
  EXPECT_EQ(r.status, 2) << r.err;
  for (const auto& f : fragments) EXPECT_NE(r.err.find(f), std::string::npos) << r.err;
  EXPECT_TRUE(is_one_error_line(r.err)) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "out"));
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    EXPECT_EQ(entry.path().filename().string().find(".out"), std::string::npos)
        << "temporary left behind: " << entry.path();
}

inline void write_text(const std::filesystem::path& path, const std::string& text) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

// f() must throw retimegs::Error with every one of `parts` in its message.
template <typename F>
void expect_error(F&& f, std::initializer_list<std::string> parts) {
  try {
    f();
  } catch (const Error& e) {
    for (const std::string& part : parts)
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what() << " / " << part;
    return;
  }
  ADD_FAILURE() << "no retimegs::Error thrown";
}

// The message of the retimegs::Error that f() throws, or "(no Error thrown)".
inline std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no Error thrown)";
}

// d loss() / d value by central differences of the given step (value restored afterwards).
template <typename T, typename Loss>
double central_difference(T& value, T step, const Loss& loss) {
  const T keep = value;
  value = keep + step;
  const double plus = loss();
  value = keep - step;
  const double minus = loss();
  value = keep;
  return (plus - minus) / (2.0 * double(step));
}

// A 64x48 pinhole camera (f = 60, principal point at the centre) at `eye` looking at the origin,
// world up -y: the small view of the CLI tests' hand-made scenes.
inline Camera small_camera(const std::string& name, const Eigen::Vector3d& eye) {
  Camera cam;
  cam.name = name;
  cam.width = 64, cam.height = 48;
  cam.fx = cam.fy = 60, cam.cx = 32, cam.cy = 24;
  cam.world_to_camera = look_at(eye, {0, 0, 0}, {0, -1, 0});
  return cam;
}

}  // namespace retimegs::test
