#include <cmath>

#include <gtest/gtest.h>

#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/model/trajectory.hpp"

namespace retimegs::model {
namespace {

constexpr double kStep = 2.0;  // Δt: every other frame held out

struct Spline {
  double mu[3] = {0.3, -1.0, 2.0};
  double v[9] = {0.4,  0.1,  -0.2,  // v1
                 1.0,  -0.5, 0.25,  // v2
                 -0.3, 0.8,  0.6};  // v3
  double mu_tau = 5.0;              // interval [4, 6]

  void at(double t, double x[3], TrajectoryKind kind = TrajectoryKind::kCatmullRom) const {
    apply_trajectory(trajectory_at(Representation::kRetime, kind, mu_tau, t, kStep), mu, v, x);
  }
  void point(int k, double p[3]) const {
    apply_trajectory(control_point<double>(k, kStep), mu, v, p);
  }
};

TEST(Trajectory, PassesThroughInnerControlPointsWithDesignTangents) {
  const Spline s;
  double p[4][3], x[3];
  for (int k = 0; k < 4; ++k) s.point(k, p[k]);
  // p1 = μ - ½Δt v2, p2 = μ + ½Δt v2, p0 = p1 - Δt v1, p3 = p2 + Δt v3.
  for (int a = 0; a < 3; ++a) {
    EXPECT_DOUBLE_EQ(p[1][a], s.mu[a] - 1.0 * s.v[3 + a]);
    EXPECT_DOUBLE_EQ(p[2][a], s.mu[a] + 1.0 * s.v[3 + a]);
    EXPECT_DOUBLE_EQ(p[0][a], p[1][a] - 2.0 * s.v[a]);
    EXPECT_DOUBLE_EQ(p[3][a], p[2][a] + 2.0 * s.v[6 + a]);
  }
  s.at(4.0, x);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(x[a], p[1][a], 1e-14);
  s.at(6.0, x);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(x[a], p[2][a], 1e-14);
  // Tangents (per unit u): ½(p2 - p0) at u = 0 and ½(p3 - p1) at u = 1, from inside and outside.
  constexpr double h = 1e-6;
  double a0[3], b0[3], a1[3], b1[3];
  for (double side : {-1.0, 1.0}) {
    s.at(4.0 + side * h * kStep, a0);
    s.at(4.0, b0);
    s.at(6.0 + side * h * kStep, a1);
    s.at(6.0, b1);
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(side * (a0[a] - b0[a]) / h, 0.5 * (p[2][a] - p[0][a]), 1e-5) << side;
      EXPECT_NEAR(side * (a1[a] - b1[a]) / h, 0.5 * (p[3][a] - p[1][a]), 1e-5) << side;
    }
  }
  // Outside its interval the curve continues linearly (bounded, C¹).
  double far[3];
  s.at(6.0 + 3 * kStep, far);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(far[a], p[2][a] + 3 * 0.5 * (p[3][a] - p[1][a]), 1e-12);
  s.at(4.0 - 2 * kStep, far);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(far[a], p[1][a] - 2 * 0.5 * (p[2][a] - p[0][a]), 1e-12);
}

TEST(Trajectory, MatchesTheCatmullRomPolynomialInside) {
  const Spline s;
  double p[4][3], x[3];
  for (int k = 0; k < 4; ++k) s.point(k, p[k]);
  for (double u : {0.1, 0.37, 0.5, 0.9}) {
    s.at(4.0 + u * kStep, x);
    for (int a = 0; a < 3; ++a) {
      const double expected = 0.5 * (2 * p[1][a] + (p[2][a] - p[0][a]) * u +
                                     (2 * p[0][a] - 5 * p[1][a] + 4 * p[2][a] - p[3][a]) * u * u +
                                     (-p[0][a] + 3 * p[1][a] - 3 * p[2][a] + p[3][a]) * u * u * u);
      EXPECT_NEAR(x[a], expected, 1e-13) << u;
    }
  }
}

TEST(Trajectory, LinearAblationAndStaticPrimitive) {
  Spline s;
  double x[3];
  s.at(5.5, x, TrajectoryKind::kLinear);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(x[a], s.mu[a] + 0.5 * s.v[3 + a], 1e-14);
  // A static primitive (zero velocities) stretched over many intervals stays put at every time.
  for (double& v : s.v) v = 0;
  for (double t = -4; t <= 30; t += 0.37) {
    s.at(t, x);
    for (int a = 0; a < 3; ++a) EXPECT_EQ(x[a], s.mu[a]) << t;
  }
}

TEST(Trajectory, VjpMatchesFiniteDifferencesInsideAndOutside) {
  for (auto rep : {Representation::kRetime, Representation::kStgs}) {
    for (double t : {4.3, 5.0, 5.9, 7.5, 1.2}) {  // inside and outside [4, 6]
      Spline s;
      const double v_x[3] = {0.7, -1.1, 0.4};
      auto loss = [&] {
        double x[3];
        apply_trajectory(trajectory_at(rep, TrajectoryKind::kCatmullRom, s.mu_tau, t, kStep), s.mu,
                         s.v, x);
        return x[0] * v_x[0] + x[1] * v_x[1] + x[2] * v_x[2];
      };
      double v_mu[3] = {}, v_v[9] = {}, v_mu_tau = 0;
      apply_trajectory_vjp(rep, trajectory_at(rep, TrajectoryKind::kCatmullRom, s.mu_tau, t, kStep),
                           s.v, v_x, v_mu, v_v, v_mu_tau);
      auto fd = [&](double& param) {
        const double keep = param, eps = 1e-6;
        param = keep + eps;
        const double up = loss();
        param = keep - eps;
        const double down = loss();
        param = keep;
        return (up - down) / (2 * eps);
      };
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(v_mu[a], fd(s.mu[a]), 1e-8);
      for (int k = 0; k < 9; ++k) EXPECT_NEAR(v_v[k], fd(s.v[k]), 1e-8) << "t " << t << " v " << k;
      if (rep == Representation::kStgs) {
        EXPECT_NEAR(v_mu_tau, fd(s.mu_tau), 1e-7);
      }
    }
  }
}

TEST(TemporalOpacity, ShortTailedWindowWithOpenClipEnds) {
  // Training times 0, 2, ..., 16; γ = 0.005 of the clip = 0.08 frames.
  const double gamma = 0.005 * 16, eps = 1e-3;
  const RetimeWindow<double> inner{5.0, 1.0, 1.0, 0.0, 16.0, gamma, eps};
  EXPECT_NEAR(inner(5.0), 1.0, 1e-4);  // sigmoid(1 / 0.08) squared
  EXPECT_NEAR(inner(4.0), 0.5, 1e-9);  // exactly half at its own edges
  EXPECT_NEAR(inner(6.0), 0.5, 1e-9);
  EXPECT_LT(inner(3.5), 1e-2);  // short-tailed: gone half a frame beyond the edge
  EXPECT_LT(inner(6.5), 1e-2);
  EXPECT_FALSE(inner.open_left());
  EXPECT_FALSE(inner.open_right());
  // First interval: open on the left (ψ_l ≡ 1), so frame 0 sees it fully.
  const RetimeWindow<double> first{1.0, 1.0, 1.0, 0.0, 16.0, gamma, eps};
  EXPECT_TRUE(first.open_left());
  EXPECT_NEAR(first(0.0), 1.0, 1e-9);
  EXPECT_NEAR(first(-3.0), 1.0, 1e-9);
  EXPECT_NEAR(first(2.0), 0.5, 1e-9);
  const RetimeWindow<double> last{15.0, 1.0, 1.0, 0.0, 16.0, gamma, eps};
  EXPECT_TRUE(last.open_right());
  EXPECT_NEAR(last(16.0), 1.0, 1e-9);
  EXPECT_NEAR(last(14.0), 0.5, 1e-9);
  // Membership of the groups around t = 4: left interval [2, 4], right [4, 6].
  const RetimeWindow<double> left_of_4{3.0, 1.0, 1.0, 0.0, 16.0, gamma, eps};
  EXPECT_TRUE(left_of_4.covers(2.0, 4.0));
  EXPECT_FALSE(left_of_4.covers(4.0, 6.0));
  const RetimeWindow<double> stretched{5.0, 3.0, 1.0, 0.0, 16.0, gamma, eps};  // covers [2, 6]
  EXPECT_TRUE(stretched.covers(2.0, 4.0));
  EXPECT_TRUE(stretched.covers(4.0, 6.0));
}

constexpr int kSeam[] = {3};

TEST(TemporalOpacity, DerivativeMatchesFiniteDifferencesInBothBoundaryCases) {
  const double gamma = 0.08, eps = 1e-3;
  const RetimeWindow<double> windows[] = {
      {5.0, 1.0, 1.0, 0.0, 16.0, gamma, eps},   // both edges soft
      {1.0, 1.0, 1.0, 0.0, 16.0, gamma, eps},   // left edge open
      {15.0, 1.0, 1.0, 0.0, 16.0, gamma, eps},  // right edge open
      // right edge at a merged model's seam (t = 6, training frame 3 of step 2): its own scale
      {5.0, 1.0, 1.0, 0.0, 16.0, gamma, eps, 2.0, kSeam, 1, 0.5},
      // the same drawn for the window before the seam (open there) or the one after it (absent)
      {5.0, 1.0, 1.0, 0.0, 16.0, gamma, eps, 2.0, kSeam, 1, 0.5, SeamSide::kBefore, 6.0},
      {5.0, 1.0, 1.0, 0.0, 16.0, gamma, eps, 2.0, kSeam, 1, 0.5, SeamSide::kAfter, 6.0},
      // left edge at the seam, drawn for the window after it (open there)
      {7.0, 1.0, 1.0, 0.0, 16.0, gamma, eps, 2.0, kSeam, 1, 0.5, SeamSide::kAfter, 6.0},
  };
  for (const auto& w : windows)
    for (double t : {w.mu_tau - 1.05, w.mu_tau - 1.0, w.mu_tau - 0.97, w.mu_tau, w.mu_tau + 0.98,
                     w.mu_tau + 1.0, w.mu_tau + 1.1}) {
      const double h = 1e-7;
      const double fd = (w(t + h) - w(t - h)) / (2 * h);
      EXPECT_NEAR(w.d_dt(t), fd, 1e-6 + 1e-6 * std::abs(fd)) << w.mu_tau << " t " << t;
    }
  // Drawn for one side of the seam at 6: the edge there is open on its own side, the primitive
  // absent on the other; an edge elsewhere, or 2ε off the seam, is untouched.
  const RetimeWindow<double>& before = windows[4];
  EXPECT_NEAR(before(6.0), 1.0, 1e-4);
  EXPECT_NEAR(before(9.0), 1.0, 1e-4);
  EXPECT_NEAR(before(4.0), 0.5, 1e-9);
  EXPECT_EQ(windows[5](5.0), 0.0);
  EXPECT_EQ(windows[5].d_dt(5.0), 0.0);
  EXPECT_NEAR(windows[6](3.0), 1.0, 1e-4);
  EXPECT_NEAR(windows[6](8.0), 0.5, 1e-9);
  const RetimeWindow<double> starts_there{
      7.0, 1.0, 1.0, 0.0, 16.0, gamma, eps, 2.0, kSeam, 1, 0.5, SeamSide::kBefore, 6.0};
  EXPECT_EQ(starts_there(7.0), 0.0);
  const RetimeWindow<double> off_seam{
      7.0 + 2 * eps, 1.0, 1.0, 0.0, 16.0, gamma, eps, 2.0, kSeam, 1, 0.5, SeamSide::kBefore, 6.0};
  EXPECT_NEAR(off_seam(6.0 + 2 * eps), 0.5, 1e-9);
  // STGS window: gradients with respect to the learnable centre and log scale.
  for (double t : {0.3, 2.0, 3.7}) {
    double mu_tau = 2.2, log_scale = std::log(0.8), v_mu = 0, v_ls = 0;
    stgs_temporal_opacity_vjp(mu_tau, log_scale, t, 1.0, v_mu, v_ls);
    const double h = 1e-6;
    EXPECT_NEAR(v_mu,
                (stgs_temporal_opacity(mu_tau + h, log_scale, t) -
                 stgs_temporal_opacity(mu_tau - h, log_scale, t)) /
                    (2 * h),
                1e-8);
    EXPECT_NEAR(v_ls,
                (stgs_temporal_opacity(mu_tau, log_scale + h, t) -
                 stgs_temporal_opacity(mu_tau, log_scale - h, t)) /
                    (2 * h),
                1e-8);
  }
}

}  // namespace
}  // namespace retimegs::model
