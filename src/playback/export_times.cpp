#include "retimegs/playback/export_times.hpp"

#include <fmt/format.h>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/interrupt.hpp"
#include "retimegs/io/splat_ply.hpp"
#include "retimegs/media/frame_writer.hpp"
#include "retimegs/model/export.hpp"

namespace retimegs::playback {

std::size_t export_time(const model::Model& model, double t, const std::filesystem::path& out,
                        bool force) {
  if (out.extension() != ".ply")
    fail("--out: a single time is written to a .ply file, got '{}'", out.string());
  check_output_free(out, force);
  model::check_times(model, {t}, "export");
  const Splats splats = model::export_splats(model, t);
  io::write_splat_ply(out, splats, /*replace=*/force);
  return splats.size();
}

void export_times(const model::Model& model, const std::vector<double>& times,
                  const std::filesystem::path& out, bool force) {
  model::check_times(model, times, "export");
  AtomicDirectory dir(out, force);
  for (std::size_t k = 0; k < times.size(); ++k) {
    throw_if_interrupted();  // Ctrl-C: `dir` removes the unfinished folder
    io::write_splat_ply(dir.temp_path() / fmt::format("{:05d}.ply", k),
                        model::export_splats(model, times[k]));
  }
  media::write_times_csv(dir.temp_path() / "times.csv", times);
  dir.commit();
}

}  // namespace retimegs::playback
