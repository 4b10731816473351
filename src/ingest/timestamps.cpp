// Per-frame timestamps of `import videos --timestamps` (timestamps.hpp).
#include "retimegs/ingest/timestamps.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <sstream>

#include <fmt/format.h>

#include "retimegs/core/error.hpp"
#include "retimegs/core/input_file.hpp"
#include "retimegs/core/limits.hpp"

namespace retimegs::ingest {

namespace {

std::string trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t\r") - first + 1);
}

// The whole field as a number (strtod: "nan" and "inf" too, so that they are named as such).
std::optional<double> number(const std::string& s) {
  if (s.empty()) return std::nullopt;
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size()) return std::nullopt;
  return v;
}

}  // namespace

Timestamps read_timestamps(const std::filesystem::path& file,
                           const std::vector<std::string>& names) {
  const std::string text = read_text_file(file, "a timestamps file");
  Timestamps out;
  out.file = file;
  const std::string where = file.string();
  std::istringstream in(text);
  std::string line;
  bool first = true;
  for (int line_number = 1; std::getline(in, line); ++line_number) {
    if (trim(line).empty()) continue;
    std::vector<std::string> fields;
    std::stringstream ss(line);
    for (std::string f; std::getline(ss, f, ',');) fields.push_back(trim(f));
    if (fields.size() != 3)
      fail("{}:{}: '{}' is not camera,frame,seconds", where, line_number, trim(line));
    const std::optional<double> frame = number(fields[1]), seconds = number(fields[2]);
    const bool header = first && !frame && !seconds;
    first = false;
    if (header) continue;
    const auto it = std::find(names.begin(), names.end(), fields[0]);
    if (it == names.end())
      fail("{}:{}: unknown camera '{}' (cameras with footage: {})", where, line_number, fields[0],
           fmt::join(names, ", "));
    if (!frame || *frame < 0 || *frame != std::floor(*frame) || *frame >= double(kMaxFrames))
      fail("{}:{}: frame '{}' is not a whole number of frames in [0, {})", where, line_number,
           fields[1], kMaxFrames);
    if (!seconds || !std::isfinite(*seconds))
      fail("{}:{}: seconds '{}' is not a finite number", where, line_number, fields[2]);
    auto& times = out.cameras[fields[0]];
    const auto [at, inserted] = times.emplace(int(*frame), FrameTimestamp{*seconds, line_number});
    if (!inserted)
      fail("{}:{}: camera '{}' frame {} is given twice (also line {})", where, line_number,
           fields[0], int(*frame), at->second.line);
  }
  for (const auto& [name, times] : out.cameras) {
    for (auto it = times.begin(), next = std::next(it); it != times.end() && next != times.end();
         ++it, ++next)
      if (!(next->second.seconds > it->second.seconds))
        fail("{}:{}: camera '{}' frame {} at {} s is not after frame {} at {} s (line {})", where,
             next->second.line, name, next->first, next->second.seconds, it->first,
             it->second.seconds, it->second.line);
  }
  return out;
}

std::vector<std::vector<double>> frame_times_from_timestamps(const Timestamps& timestamps,
                                                             const std::vector<std::string>& names,
                                                             const std::vector<int>& first,
                                                             int count, double fps) {
  const auto seconds = [&](std::size_t c, int k) {
    const int frame = first[c] + k;
    if (const auto times = timestamps.cameras.find(names[c]); times != timestamps.cameras.end())
      if (const auto it = times->second.find(frame); it != times->second.end())
        return it->second.seconds;
    fail("{}: no timestamp for camera '{}' frame {} (its scene frame {})", timestamps.file.string(),
         names[c], frame, k);
  };
  std::vector<std::vector<double>> out(names.size());
  if (names.empty()) return out;
  const double origin = seconds(0, 0);
  for (std::size_t c = 0; c < names.size(); ++c)
    for (int k = 0; k < count; ++k) out[c].push_back((seconds(c, k) - origin) * fps);
  return out;
}

}  // namespace retimegs::ingest
