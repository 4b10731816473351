#pragma once
// `retimegs export`: the 3D Gaussians of a 4D model at given times (model::export_splats) as
// standard 3DGS .ply files (Inria layout) that SuperSplat and other splat viewers open.
#include <cstddef>
#include <filesystem>
#include <vector>

#include "retimegs/model/model_file.hpp"

namespace retimegs::playback {

// The Gaussians at time t as `out`, a .ply file, replaced only with `force`; returns how many.
// Throws Error naming --out when `out` is not a .ply file or exists, and as model::check_times
// when t lies outside the model's time range; nothing is written then.
std::size_t export_time(const model::Model& model, double t, const std::filesystem::path& out,
                        bool force);

// The Gaussians at times[k] as folder `out`/<k:05d>.ply with `out`/times.csv
// (media::write_times_csv), written whole or not at all (an error or Ctrl-C leaves nothing), an
// existing folder replaced only with `force`. Throws Error as export_time on a time out of range,
// before anything is written.
void export_times(const model::Model& model, const std::vector<double>& times,
                  const std::filesystem::path& out, bool force);

}  // namespace retimegs::playback
