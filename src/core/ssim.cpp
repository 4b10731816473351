#include "retimegs/core/ssim.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <omp.h>

#include "retimegs/core/error.hpp"
#include "retimegs/core/ssim_formulas.hpp"

namespace retimegs {
namespace {

constexpr int kMoments = 3;        // of the render per window: μ_a, E[a²], E[ab]
constexpr int kTargetMoments = 2;  // of the target (SsimTarget): μ_b, E[b²]
constexpr int kCoefficients = 3;   // dS/dμ_a, dS/dE[a²], dS/dE[ab]
// Below this many values (~128×128) waking the threads costs more than the passes.
constexpr std::size_t kParallelMin = std::size_t(1) << 14;

const SsimWindow& window() {
  static const SsimWindow w = ssim_window();
  return w;
}

void check_same_size(const Image& a, const Image& b, const char* what) {
  if (a.width != b.width || a.height != b.height || a.channels != b.channels)
    fail("{}: images differ in size ({}x{}x{} vs {}x{}x{})", what, a.width, a.height, a.channels,
         b.width, b.height, b.channels);
  if (a.empty()) fail("{}: images are empty", what);
}

using LocalSsim = LocalSsimT<double>;

// Pass along x: out[j] = Σ_k w[k]·src[j + k·c] for j < n, where src is an interleaved row of c
// channels with kSsimRadius pixels of zeros on either side (the zero padding).
inline void correlate_x(const double* src, int c, std::size_t n, double* out) {
  const SsimWindow w = window();  // a local copy: provably not aliased by out
#pragma omp simd
  for (std::size_t j = 0; j < n; ++j) {
    double sum = 0;
    for (int k = 0; k < kSsimTaps; ++k) sum += w[k] * src[j + k * std::size_t(c)];
    out[j] = sum;
  }
}

// Rows are streamed through rings of kSsimTaps rows: image row r lives in slot r mod kSsimTaps.
inline int slot(int row) {
  return (row % kSsimTaps + kSsimTaps) % kSsimTaps;
}

// Pass along y: out[j] = Σ_k w[k]·row(y − r + k)[j], the rows taken from a ring [kSsimTaps, n].
inline void correlate_y(const double* ring, std::size_t n, int y, double* out) {
  const SsimWindow w = window();
  std::array<const double*, kSsimTaps> rows;
  for (int k = 0; k < kSsimTaps; ++k) rows[k] = ring + slot(y - kSsimRadius + k) * n;
#pragma omp simd
  for (std::size_t j = 0; j < n; ++j) {
    double sum = 0;
    for (int k = 0; k < kSsimTaps; ++k) sum += w[k] * rows[k][j];
    out[j] = sum;
  }
}

// One row of the SSIM map from the render's moments [3, n] (μ_a, E[a²], E[ab]) and the target's
// mu_b [n], e_bb [n]: its sum, the map row with kWithMap, and with kBackward the coefficients
// scale · dS/d(μ_a, E[a²], E[ab]).
template <bool kWithMap, bool kBackward>
double ssim_row(const double* moments, const double* mu_b, const double* e_bb, std::size_t n,
                double scale, float* map_row, std::array<double*, kCoefficients> coefficients) {
  const double *mu_a = moments, *e_aa = mu_a + n, *e_ab = e_aa + n;
  double sum = 0;
#pragma omp simd reduction(+ : sum)
  for (std::size_t j = 0; j < n; ++j) {
    const LocalSsim l = local_ssim<double>(mu_a[j], mu_b[j], e_aa[j], e_bb[j], e_ab[j]);
    sum += l.s;
    if constexpr (kWithMap) map_row[j] = float(l.s);
    if constexpr (kBackward) {
      coefficients[0][j] = scale * l.d_mu_a;
      coefficients[1][j] = scale * l.d_e_aa;
      coefficients[2][j] = scale * l.d_e_ab;
    }
  }
  return sum;
}

// Each thread owns a band of rows [begin, end) of the image (height rows; none when it is small).
template <typename F>
void for_each_band(int height, std::size_t n, F&& band) {
#pragma omp parallel if (std::size_t(height) * n >= kParallelMin)
  {
    const int threads = omp_get_num_threads(), thread = omp_get_thread_num();
    band(int(std::int64_t(height) * thread / threads),
         int(std::int64_t(height) * (thread + 1) / threads));
  }
}

// The target's window moments μ_b, E[b²] [H, W·C] each, streamed as ssim_separable's pass 1 and 2
// stream the render's (the same operations in the same order, so the same values).
void target_moments(const Image& b, double* mu, double* e_sq) {
  const int height = b.height, c = b.channels;
  const std::size_t n = std::size_t(b.width) * c;
  const std::size_t padded_n = n + 2 * std::size_t(kSsimRadius) * c;
  for_each_band(height, n, [&](int begin, int end) {
    std::vector<double> src(kTargetMoments * padded_n, 0.0);      // [2, W·C + 2r·C] zero-padded
    std::vector<double> along_x(kTargetMoments * kSsimTaps * n);  // [2, 11, W·C] ring of pass 1
    double* out[kTargetMoments] = {mu, e_sq};
    for (int r1 = begin - kSsimRadius; r1 < end + kSsimRadius; ++r1) {
      const std::size_t s1 = slot(r1) * n;
      if (r1 < 0 || r1 >= height) {
        for (int m = 0; m < kTargetMoments; ++m)
          std::fill_n(&along_x[(m * kSsimTaps) * n + s1], n, 0.0);
      } else {
        const float* row_b = b.data.data() + r1 * n;
        double* s = src.data() + kSsimRadius * c;
        for (std::size_t j = 0; j < n; ++j) {
          const double vb = row_b[j];
          s[j] = vb;
          s[padded_n + j] = vb * vb;
        }
        for (int m = 0; m < kTargetMoments; ++m)
          correlate_x(src.data() + m * padded_n, c, n, &along_x[(m * kSsimTaps) * n + s1]);
      }
      const int r2 = r1 - kSsimRadius;
      if (r2 < begin) continue;
      for (int m = 0; m < kTargetMoments; ++m)
        correlate_y(&along_x[m * kSsimTaps * n], n, r2, out[m] + r2 * n);
    }
  });
}

// The separable fast path against a prepared target. Each thread owns a band of output rows and
// streams the render through it, top to bottom, so that its working set is a few rings of 11 rows
// (cache resident):
//   pass 1  row r1: the moment rows a, a², ab correlated along x → ring `along_x`;
//   pass 2  row r2 = r1 − r: along y → moments (with the target's μ_b, E[b²]) → map row, and
//           (backward) the coefficient row scale · dS/d(μ_a, E[a²], E[ab]) → ring `coefficient`;
//   backward row r3 = r2 − r: the transpose, along y then x, and the chain rule through a, a², ab:
//           v_a(q) = Σ_p w(p − q)·(c_μ(p) + 2·a(q)·c_aa(p) + b(q)·c_ab(p)), added into v_add.
// A band recomputes the r (forward) or 2r (backward) rows of pass 1 beyond its edges; rows
// outside the image are zero (the zero padding).
double ssim_separable(const Image& a, const SsimTarget& target, Image* map, double v_ssim,
                      Image* v_add) {
  const Image& b = *target.image;
  const int height = a.height, c = a.channels;
  const std::size_t n = std::size_t(a.width) * c;  // values in one row
  const std::size_t padded_n =
      n + 2 * std::size_t(kSsimRadius) * c;                    // with r zero pixels each side
  const double scale = v_ssim / (double(height) * double(n));  // d mean / d S(p) · upstream
  const bool backward = v_add != nullptr;
  const int halo =
      backward ? 2 * kSsimRadius : kSsimRadius;  // rows of pass 1 beyond a band's edges
  if (map) *map = Image(a.width, height, c);
  const auto inside = [height](int row) { return row >= 0 && row < height; };

  std::vector<double> row_sums(height);  // [H] of the map, summed in row order below
  for_each_band(height, n, [&](int begin, int end) {
    std::vector<double> src(kMoments * padded_n, 0.0);      // [3, W·C + 2r·C] zero-padded rows
    std::vector<double> along_x(kMoments * kSsimTaps * n);  // [3, 11, W·C] ring of pass 1
    std::vector<double> moments(kMoments * n);              // [3, W·C] one row of pass 2
    std::vector<double> coefficient(backward ? kCoefficients * kSsimTaps * n : 0);  // [3, 11, W·C]

    for (int r1 = begin - halo; r1 < end + halo; ++r1) {
      const std::size_t s1 = slot(r1) * n;
      if (!inside(r1)) {
        for (int m = 0; m < kMoments; ++m) std::fill_n(&along_x[(m * kSsimTaps) * n + s1], n, 0.0);
      } else {
        const float* row_a = a.data.data() + r1 * n;
        const float* row_b = b.data.data() + r1 * n;
        double* s = src.data() + kSsimRadius * c;
        for (std::size_t j = 0; j < n; ++j) {
          const double va = row_a[j], vb = row_b[j];
          s[j] = va;
          s[padded_n + j] = va * va;
          s[2 * padded_n + j] = va * vb;
        }
        for (int m = 0; m < kMoments; ++m)
          correlate_x(src.data() + m * padded_n, c, n, &along_x[(m * kSsimTaps) * n + s1]);
      }

      const int r2 = r1 - kSsimRadius;
      if (r2 - kSsimRadius < begin - halo) continue;  // its rows of pass 1 are not all there yet
      const std::size_t s2 = slot(r2) * n;
      const std::array<double*, kCoefficients> coefficient_row =
          backward ? std::array<double*, kCoefficients>{&coefficient[s2],
                                                        &coefficient[kSsimTaps * n + s2],
                                                        &coefficient[2 * kSsimTaps * n + s2]}
                   : std::array<double*, kCoefficients>{};
      if (!inside(r2)) {
        for (double* row : coefficient_row)
          if (row) std::fill_n(row, n, 0.0);
      } else {
        for (int m = 0; m < kMoments; ++m)
          correlate_y(&along_x[m * kSsimTaps * n], n, r2, &moments[m * n]);
        const double* mu_b = target.mu.data() + r2 * n;
        const double* e_bb = target.e_sq.data() + r2 * n;
        const bool own = r2 >= begin && r2 < end;  // halo rows belong to the neighbour band
        double sum;
        if (backward)
          sum =
              ssim_row<false, true>(moments.data(), mu_b, e_bb, n, scale, nullptr, coefficient_row);
        else if (map)
          sum = ssim_row<true, false>(moments.data(), mu_b, e_bb, n, scale,
                                      map->data.data() + r2 * n, {});
        else
          sum = ssim_row<false, false>(moments.data(), mu_b, e_bb, n, scale, nullptr, {});
        if (own) row_sums[r2] = sum;
      }

      const int r3 = r2 - kSsimRadius;
      if (!backward || r3 < begin) continue;
      for (int m = 0; m < kCoefficients; ++m)
        correlate_y(&coefficient[m * kSsimTaps * n], n, r3,
                    src.data() + m * padded_n + kSsimRadius * c);
      const double* c_mu = src.data();
      const double *c_aa = c_mu + padded_n, *c_ab = c_aa + padded_n;
      const float* row_a = a.data.data() + r3 * n;
      const float* row_b = b.data.data() + r3 * n;
      double* grad = moments.data();  // [W·C]: the moment row is not read again for this r1
      const SsimWindow w = window();
#pragma omp simd
      for (std::size_t j = 0; j < n; ++j) {
        double g_mu = 0, g_aa = 0, g_ab = 0;
        for (int k = 0; k < kSsimTaps; ++k) {
          const std::size_t at = j + k * std::size_t(c);
          g_mu += w[k] * c_mu[at];
          g_aa += w[k] * c_aa[at];
          g_ab += w[k] * c_ab[at];
        }
        grad[j] = ssim_pixel_gradient<double>(g_mu, g_aa, g_ab, row_a[j], row_b[j]);
      }
      const int out_c = v_add->channels;
      float* out = v_add->data.data() + std::size_t(r3) * a.width * out_c;
      if (out_c == c) {
#pragma omp simd
        for (std::size_t j = 0; j < n; ++j) out[j] += float(grad[j]);
      } else if (c == 3) {  // an RGB render's gradient among its flow channels
        for (int x = 0; x < a.width; ++x)
          for (int ch = 0; ch < 3; ++ch) out[x * out_c + ch] += float(grad[x * 3 + ch]);
      } else {
        for (int x = 0; x < a.width; ++x)
          for (int ch = 0; ch < c; ++ch) out[x * out_c + ch] += float(grad[x * c + ch]);
      }
    }
  });
  double total = 0;  // summed in row order: the same value for any thread count
  for (const double s : row_sums) total += s;
  return total / (double(height) * double(n));
}

// The moments μ_a, μ_b, E[a²], E[b²], E[ab] of the window centred on (y, x) in channel ch, zero
// outside the image.
std::array<double, 5> window_moments(const Image& a, const Image& b, int y, int x, int ch) {
  const SsimWindow& w = window();
  std::array<double, 5> m{};
  for (int dy = -kSsimRadius; dy <= kSsimRadius; ++dy) {
    for (int dx = -kSsimRadius; dx <= kSsimRadius; ++dx) {
      const int yy = y + dy, xx = x + dx;
      if (yy < 0 || yy >= a.height || xx < 0 || xx >= a.width) continue;
      const double weight = w[dy + kSsimRadius] * w[dx + kSsimRadius];
      const double va = a.at(yy, xx, ch), vb = b.at(yy, xx, ch);
      m[0] += weight * va;
      m[1] += weight * vb;
      m[2] += weight * va * va;
      m[3] += weight * vb * vb;
      m[4] += weight * va * vb;
    }
  }
  return m;
}

LocalSsim reference_local(const Image& a, const Image& b, int y, int x, int ch) {
  const auto m = window_moments(a, b, y, x, ch);
  return local_ssim<double>(m[0], m[1], m[2], m[3], m[4]);
}

}  // namespace

void SsimTarget::assign(const Image& b) {
  if (b.empty()) fail("ssim target: image is empty");
  image = &b;
  mu.resize(b.data.size());
  e_sq.resize(b.data.size());
  target_moments(b, mu.data(), e_sq.data());
}

double ssim(const Image& a, const Image& b, Image* map) {
  check_same_size(a, b, "ssim");
  SsimTarget target;
  target.assign(b);
  return ssim_separable(a, target, map, 0.0, nullptr);
}

double ssim_backward(const Image& a, const Image& b, double v_ssim, Image& v_a) {
  check_same_size(a, b, "ssim_backward");
  SsimTarget target;
  target.assign(b);
  v_a = Image(a.width, a.height, a.channels);
  return ssim_separable(a, target, nullptr, v_ssim, &v_a);
}

double ssim_backward_add(const Image& a, const SsimTarget& b, double v_ssim, Image& v_out) {
  if (!b.image || b.mu.size() != b.image->data.size())
    fail("ssim_backward_add: the target was not prepared (SsimTarget::assign)");
  check_same_size(a, *b.image, "ssim_backward_add");
  if (v_out.width != a.width || v_out.height != a.height || v_out.channels < a.channels)
    fail("ssim_backward_add: gradient {}x{}x{} cannot hold a {}x{}x{} image's", v_out.width,
         v_out.height, v_out.channels, a.width, a.height, a.channels);
  return ssim_separable(a, b, nullptr, v_ssim, &v_out);
}

double ssim_reference(const Image& a, const Image& b, Image* map) {
  check_same_size(a, b, "ssim_reference");
  if (map) *map = Image(a.width, a.height, a.channels);
  double sum = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x)
      for (int ch = 0; ch < a.channels; ++ch) {
        const double s = reference_local(a, b, y, x, ch).s;
        sum += s;
        if (map) map->at(y, x, ch) = float(s);
      }
  return sum / double(a.data.size());
}

double ssim_backward_reference(const Image& a, const Image& b, double v_ssim, Image& v_a) {
  check_same_size(a, b, "ssim_backward_reference");
  const int c = a.channels;
  std::vector<LocalSsim> local(a.data.size());  // [H, W, C]
  double sum = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x)
      for (int ch = 0; ch < c; ++ch) {
        local[(std::size_t(y) * a.width + x) * c + ch] = reference_local(a, b, y, x, ch);
        sum += local[(std::size_t(y) * a.width + x) * c + ch].s;
      }
  const double scale = v_ssim / double(a.data.size());
  const SsimWindow& w = window();
  v_a = Image(a.width, a.height, c);
  // Pixel q enters every window p with |p − q| ≤ r, through μ_a(p), E[a²](p) and E[ab](p).
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x)
      for (int ch = 0; ch < c; ++ch) {
        double g = 0;
        for (int dy = -kSsimRadius; dy <= kSsimRadius; ++dy)
          for (int dx = -kSsimRadius; dx <= kSsimRadius; ++dx) {
            const int py = y + dy, px = x + dx;
            if (py < 0 || py >= a.height || px < 0 || px >= a.width) continue;
            const LocalSsim& l = local[(std::size_t(py) * a.width + px) * c + ch];
            const double weight = w[dy + kSsimRadius] * w[dx + kSsimRadius];
            g += weight * ssim_pixel_gradient<double>(l.d_mu_a, l.d_e_aa, l.d_e_ab, a.at(y, x, ch),
                                                      b.at(y, x, ch));
          }
        v_a.at(y, x, ch) = float(scale * g);
      }
  return sum / double(a.data.size());
}

}  // namespace retimegs
