// The viewer's time model (web/time_model.js) against the C++ one. This test writes the cases that
// web/test/time_model.test.mjs checks: three small models packed as the viewer reads them
// (view::pack: DIR/<model>/model.json, model.bin), the C++ values at chosen times in
// DIR/cases.json, and float_from_half of every half float in DIR/halves.f32. ctest runs it as
// time_model_cases with DIR = $RETIMEGS_TIME_MODEL_CASES, then the node test (time_model_js).
//
// The rows cover windows closed on both sides, open at the first or the last training time (and
// within ε of it), stretched over several intervals or the whole clip, a soft edge inside an
// interval, the linear trajectory and STGS rows; the times lie inside, at and beyond each window
// edge and between training frames, so that Catmull-Rom positions are taken inside their interval
// and on its linear continuation. The values are in double, by the functions export uses, from
// the model's float parameters: what the viewer's JavaScript computes from model.bin. The render's
// own float path (model::evaluate) is checked against them here.
//
// A merged model (two seams) adds, at each case time, σ_τ of every row drawn with each side of
// the seam nearest that time (model::SeamSide, the image-domain handover), and the handover itself
// (model::seam_handover: the nearest seam, the weight before it, which sides are drawn) at times
// across the clip, at and around each seam and on both sides of where a side's weight reaches the
// tail (model::kHandoverTail).
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <optional>
#include <random>
#include <set>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "retimegs/model/sh.hpp"
#include "retimegs/model/slice.hpp"
#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/model/trajectory.hpp"
#include "retimegs/view/pack.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;

// One row's temporal parameters: μ_τ and (Retime) τ_l, τ_r or (STGS) the temporal log-scale.
struct RowTime {
  float mu_tau, tau_l, tau_r, temporal_log_scale;
};

struct CaseModel {
  std::string name;
  model::Model model;
};

// A model of one row per entry of `rows`, other parameters random but fixed by `seed`. Velocities
// (STGS: the polynomial's b1, b2, b3) differ per row and per v_j so that every coefficient of the
// trajectory shows in x(t).
CaseModel case_model(std::string name, model::Representation representation,
                     model::TrajectoryKind trajectory, const model::TimeGrid& grid, double gamma,
                     const std::vector<RowTime>& rows, unsigned seed) {
  CaseModel c{std::move(name), {}};
  model::Model& m = c.model;
  m.grid = grid;
  m.config.representation = representation;
  m.config.trajectory = trajectory;
  m.config.gamma = gamma;
  m.config.sh_degree = 1;
  model::Primitives& p = m.primitives;
  p.resize(rows.size());
  std::mt19937 rng(seed);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  const bool stgs = representation == model::Representation::kStgs;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    for (int a = 0; a < 3; ++a) p.mu[3 * i + a] = normal(rng);
    for (int j = 0; j < 3; ++j) {
      // STGS: b_j Δ^(j+1) over Δ up to the clip's length stays of the order of the scene.
      const float scale = stgs ? 0.3f * std::pow(0.1f, float(j)) : 0.3f;
      for (int a = 0; a < 3; ++a) p.velocity[9 * i + 3 * j + a] = scale * normal(rng);
    }
    for (int a = 0; a < 3; ++a) p.log_scale[3 * i + a] = -3.0f + 0.5f * normal(rng);
    for (int a = 0; a < 4; ++a) p.q0[4 * i + a] = normal(rng), p.q1[4 * i + a] = 0.1f * normal(rng);
    for (int k = 0; k < 3 * model::sh_coeffs(1); ++k)
      p.sh[model::Primitives::kShWidth * i + k] = normal(rng);
    p.opacity_logit[i] = 0.5f + 1.5f * normal(rng);
    p.mu_tau[i] = rows[i].mu_tau;
    p.tau_l[i] = rows[i].tau_l;
    p.tau_r[i] = rows[i].tau_r;
    p.temporal_log_scale[i] = rows[i].temporal_log_scale;
  }
  return c;
}

std::vector<CaseModel> case_models() {
  const float no_scale = 0;  // Retime rows: the STGS scale is unused
  // Training frames 0, 2, ..., 16; γ = 0.005 (0.08 frames), ε = 1e-3 frames.
  const model::TimeGrid even{0.0, 2.0, 9};
  const std::vector<RowTime> windows = {
      {5, 1, 1, no_scale},        // [4, 6]: both edges closed
      {1, 1, 1, no_scale},        // [0, 2]: open at the first training time
      {15, 1, 1, no_scale},       // [14, 16]: open at the last
      {1.0005f, 1, 1, no_scale},  // left edge 0.0005 frames after the first time: within ε, open
      {1.002f, 1, 1, no_scale},   // left edge 0.002 frames after it: beyond ε, closed
      {5, 3, 1, no_scale},        // stretched over [2, 6]
      {7, 7, 9, no_scale},        // stretched over the whole clip: open at both ends
      {9, 1, 0.5f, no_scale},     // a soft edge inside the interval [8, 10], at 9.5
      {13, 5, 1.25f, no_scale},   // stretched left to 8, a soft edge at 14.25
  };
  // Training frames 3, 4, ..., 14 (one frame apart), γ = 0.01 (0.11 frames).
  const model::TimeGrid unit{3.0, 1.0, 12};
  const std::vector<RowTime> linear_windows = {
      {3.5f, 0.5f, 0.5f, no_scale}, {8.5f, 0.5f, 0.5f, no_scale}, {13.5f, 0.5f, 0.5f, no_scale},
      {6.5f, 2.5f, 1.5f, no_scale}, {8.5f, 5.5f, 5.5f, no_scale},
  };
  const std::vector<RowTime> stgs_rows = {
      {0.5f, 0, 0, std::log(1.5f)}, {5, 0, 0, std::log(0.4f)},     {8.3f, 0, 0, std::log(3.0f)},
      {16, 0, 0, std::log(6.0f)},   {11.7f, 0, 0, std::log(0.9f)},
  };
  std::vector<CaseModel> models;
  models.push_back(case_model("retime", model::Representation::kRetime,
                              model::TrajectoryKind::kCatmullRom, even, 0.005, windows, 11));
  models.push_back(case_model("linear", model::Representation::kRetime,
                              model::TrajectoryKind::kLinear, unit, 0.01, linear_windows, 12));
  // A merged model: windows meeting at t = 8 and t = 12 (training frames 4 and 6), their seam
  // edges on a scale of 0.3 intervals.
  const std::vector<RowTime> merged_windows = {
      {7, 1, 1, no_scale},     // [6, 8]: the first window's, its right edge at the seam
      {9, 1, 1, no_scale},     // [8, 10]: the second's, its left edge at the seam
      {5, 3, 3, no_scale},     // stretched over [2, 8]
      {9, 1, 0.5f, no_scale},  // an edge at 9.5: γ
      {8.5f, 1, 1, no_scale},  // edges at 7.5 and 9.5, off the seam: γ
      {10, 2, 2, no_scale},    // [8, 12]: the second window's, from seam to seam
      {11, 1, 1, no_scale},    // [10, 12]: its right edge at the second seam
      {13, 1, 1, no_scale},    // [12, 14]: the third window's, its left edge there
  };
  CaseModel merged =
      case_model("merged", model::Representation::kRetime, model::TrajectoryKind::kCatmullRom, even,
                 0.005, merged_windows, 14);
  merged.model.config.seams = {4, 6};
  merged.model.config.seam_fade = 0.3;
  models.push_back(std::move(merged));
  models.push_back(case_model("stgs", model::Representation::kStgs,
                              model::TrajectoryKind::kCatmullRom, even, 0.005, stgs_rows, 13));
  return models;
}

// The times of row i's cases: the clip's ends, the row's centre, points around each window edge
// (STGS: around the centre, in units of its temporal scale) and between training frames; all in
// the clip, where the viewer's timeline keeps t.
std::vector<double> case_times(const model::Model& m, std::size_t i) {
  const model::Primitives& p = m.primitives;
  const double first = m.grid.first, last = m.grid.last(), mu_tau = p.mu_tau[i];
  std::set<double> times = {first, last, mu_tau};
  for (const double between : {0.37, 0.5, 0.81}) times.insert(first + between * m.grid.step);
  for (const double between : {0.37, 0.5, 0.81}) times.insert(mu_tau + between * m.grid.step);
  if (m.config.representation == model::Representation::kStgs) {
    const double scale = std::exp(double(p.temporal_log_scale[i]));
    for (const double d : {-3.0, -1.5, -1.0, -0.4, 0.25, 1.0, 2.0, 3.0})
      times.insert(mu_tau + d * scale);
  } else {
    for (const double edge : {mu_tau - p.tau_l[i], mu_tau + double(p.tau_r[i])})
      for (const double d : {-2.5, -0.3, -0.08, -0.02, 0.0, 0.02, 0.08, 0.3, 2.5})
        times.insert(edge + d);
  }
  std::vector<double> in_clip;
  for (const double t : times)
    if (t >= first && t <= last) in_clip.push_back(t);
  return in_clip;
}

// The C++ values of one case, from the model's float parameters in double.
struct CaseValues {
  double temporal;
  double coefficients[3];
  double x[3];
};

// σ_τ(t) of row i drawn with `side` of the seam at `seam` (frames).
double side_temporal(const model::Model& m, std::size_t i, double t, model::SeamSide side,
                     double seam) {
  model::RetimeWindow<double> w =
      model::retime_window<float, double>(m.primitives, i, m.config, m.grid);
  w.side = side, w.side_seam = seam;
  return w(t);
}

CaseValues case_values(const model::Model& m, std::size_t i, double t) {
  const model::Primitives& p = m.primitives;
  CaseValues v;
  v.temporal = model::temporal_opacity(p, i, m.config, m.grid, t);
  const model::TrajectoryCoefficients<double> c = model::trajectory_at<double>(
      m.config.representation, m.config.trajectory, p.mu_tau[i], t, m.grid.step);
  const double mu[3] = {p.mu[3 * i], p.mu[3 * i + 1], p.mu[3 * i + 2]};
  double velocity[9];
  std::copy_n(&p.velocity[9 * i], 9, velocity);
  model::apply_trajectory(c, mu, velocity, v.x);
  std::copy_n(c.coef, 3, v.coefficients);
  return v;
}

// σ as the viewer holds it: the logit through a half float, σ in float32 (model_data.js).
float viewer_opacity(float logit) {
  const double h = view::float_from_half(view::half_from_float(logit));
  return float(1 / (1 + std::exp(-h)));
}

// The render's evaluation (float) of row i at t, or nothing when it dropped the row.
struct Rendered {
  float temporal;
  float x[3];
};
std::optional<Rendered> rendered(const model::Model& m, std::size_t i, double t,
                                 model::SeamSide side = model::SeamSide::kNone, double seam = 0) {
  Camera camera;
  camera.width = camera.height = 64;
  camera.fx = camera.fy = 50, camera.cx = camera.cy = 32;
  camera.world_to_camera(2, 3) = 5;
  model::SliceOptions options;
  options.min_opacity = 0;
  options.side = side, options.side_seam = seam;
  const model::TimeSlice e = model::slice(m.primitives, m.config, m.grid, t, camera, options);
  for (std::size_t row = 0; row < e.primitive_from_gaussian.size(); ++row)
    if (std::size_t(e.primitive_from_gaussian[row]) == i) {
      Rendered r{e.temporal[row], {}};
      std::copy_n(&e.gaussians.means[3 * row], 3, r.x);
      return r;
    }
  return std::nullopt;
}

// Where the cases go: $RETIMEGS_TIME_MODEL_CASES under ctest (for the node test), else a
// temporary folder.
fs::path output_dir(const test::TempDir& scratch) {
  const char* dir = std::getenv("RETIMEGS_TIME_MODEL_CASES");
  return dir && *dir ? fs::path(dir) : scratch.path();
}

void write_file(const fs::path& path, const void* data, std::size_t bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(static_cast<const char*>(data), std::streamsize(bytes));
  out.close();
  ASSERT_TRUE(out) << path;
}

// The render's float path against the double values of row i at t, within float rounding: σ_τ
// within that of a window edge's argument (t - edge) / γ (up to 3.4e-6 relative on these cases; a
// subnormal σ_τ within its last bit), x (when given) within that of its terms (up to 2.8e-7). It
// leaves out the rows whose σ_τ underflows to 0 in float, below float's smallest normal, and
// those that `side` leaves out.
void expect_rendered(const CaseModel& c, std::size_t i, double t, double temporal, const double* x,
                     model::SeamSide side = model::SeamSide::kNone, double seam = 0) {
  const std::optional<Rendered> r = rendered(c.model, i, t, side, seam);
  if (!r) {
    EXPECT_LT(temporal, std::numeric_limits<float>::min())
        << c.name << " row " << i << " t " << t << " side " << int(side);
    return;
  }
  EXPECT_NEAR(r->temporal, temporal, 2e-5 * temporal + std::numeric_limits<float>::denorm_min())
      << c.name << " row " << i << " t " << t << " side " << int(side);
  for (int a = 0; x && a < 3; ++a)
    EXPECT_NEAR(r->x[a], x[a], 2e-6 * (1 + std::abs(x[a])))
        << c.name << " row " << i << " t " << t << " axis " << a;
}

// The times of a merged model's handover cases: every eighth of a frame over the clip, and around
// each seam at multiples of its scale F (at the seam, before = 1/2) and a millionth of a frame
// either side of where the far side's weight reaches the tail (F ln(1/tail - 1) from the seam).
// None for a model without seams.
std::vector<double> handover_times(const model::Model& m) {
  if (m.config.seams.empty()) return {};
  std::set<double> times;
  const double first = m.grid.first, last = m.grid.last();
  for (double t = first; t <= last; t += 0.125) times.insert(t);
  const double scale = model::seam_scale_frames(m.config, m.grid);
  const double tail = scale * std::log(1 / model::kHandoverTail - 1);
  for (const int k : m.config.seams) {
    const double seam = m.grid.at(k);
    for (const double d : {0.0, 0.5, 1.0, 3.0})
      times.insert(seam - d * scale), times.insert(seam + d * scale);
    for (const double d : {tail - 1e-6, tail + 1e-6})
      times.insert(seam - d), times.insert(seam + d);
  }
  std::vector<double> in_clip;
  for (const double t : times)
    if (t >= first && t <= last) in_clip.push_back(t);
  return in_clip;
}

TEST(TimeModelCases, WritesTheCasesTheViewerIsCheckedAgainst) {
  const test::TempDir scratch;
  const fs::path dir = output_dir(scratch);
  fs::create_directories(dir);
  json models = json::array();
  std::size_t count = 0;
  // Side cases where one side leaves the row out (σ_τ = 0) while the other draws it, and where a
  // side draws it (nearly) whole, its edge at the seam open, while the model without sides fades
  // it.
  std::size_t left_out = 0, opened = 0;
  for (const CaseModel& c : case_models()) {
    const model::Model& m = c.model;
    const view::Packed packed = view::pack(m, {});
    fs::create_directories(dir / c.name);
    write_file(dir / c.name / "model.json", packed.manifest.data(), packed.manifest.size());
    write_file(dir / c.name / "model.bin", packed.data.data(), packed.data.size());
    json cases = json::array();
    for (std::size_t i = 0; i < m.primitives.size(); ++i) {
      for (const double t : case_times(m, i)) {
        const CaseValues v = case_values(m, i, t);
        json k = {{"row", i},
                  {"t", t},
                  {"temporal", v.temporal},
                  {"opacity", viewer_opacity(m.primitives.opacity_logit[i])},
                  {"coefficients", v.coefficients},
                  {"x", v.x}};
        expect_rendered(c, i, t, v.temporal, v.x);
        if (const auto h = model::seam_handover(m.config, m.grid, t)) {
          const double before = side_temporal(m, i, t, model::SeamSide::kBefore, h->seam);
          const double after = side_temporal(m, i, t, model::SeamSide::kAfter, h->seam);
          k["side_seam"] = h->seam, k["temporal_before"] = before, k["temporal_after"] = after;
          expect_rendered(c, i, t, before, nullptr, model::SeamSide::kBefore, h->seam);
          expect_rendered(c, i, t, after, nullptr, model::SeamSide::kAfter, h->seam);
          left_out += (before == 0) != (after == 0);
          opened += (before > 0.99 || after > 0.99) && v.temporal < 0.99;
        }
        cases.push_back(std::move(k));
        ++count;
      }
    }
    json handovers = json::array();
    for (const double t : handover_times(m)) {
      const model::SeamHandover h = *model::seam_handover(m.config, m.grid, t);
      handovers.push_back({{"t", t},
                           {"seam", h.seam},
                           {"before", h.before},
                           {"draws_before", h.draws(model::SeamSide::kBefore)},
                           {"draws_after", h.draws(model::SeamSide::kAfter)}});
    }
    models.push_back({{"name", c.name}, {"cases", cases}, {"handovers", handovers}});
  }
  std::vector<float> halves(0x10000);
  for (std::uint32_t h = 0; h < 0x10000; ++h) halves[h] = view::float_from_half(std::uint16_t(h));
  write_file(dir / "halves.f32", halves.data(), halves.size() * sizeof(float));
  const std::string manifest = json({{"models", models}, {"halves", "halves.f32"}}).dump(1);
  write_file(dir / "cases.json", manifest.data(), manifest.size());
  EXPECT_GT(count, 200u);
  EXPECT_GT(left_out, 10u);
  EXPECT_GT(opened, 10u);
}

}  // namespace
}  // namespace retimegs
