#include "retimegs/eval/flow_interpolate.hpp"

#include <cmath>
#include <vector>

#include "retimegs/core/error.hpp"
#include "retimegs/core/parallel.hpp"

namespace retimegs::eval {
namespace {

// Splat precedence of a flow vector (larger wins): any known flow beats an unknown one, then the
// larger motion. 0 marks a pixel nothing has landed on.
float splat_key(bool known, float u, float v) {
  return known ? 1.0f + u * u + v * v : 0.5f;
}

// Step 1 of the header: the a -> b flow at time alpha, [H, W, 2].
std::vector<float> flow_at_time(const prepare::FlowPair& flows, double alpha) {
  const int w = flows.forward.width, h = flows.forward.height;
  std::vector<float> uv(std::size_t(w) * h * 2, 0.0f);
  std::vector<float> key(std::size_t(w) * h, 0.0f);
  // Pixels of `flow` move by `fraction` of their flow; they carry `sign` times it (a -> b).
  const auto splat = [&](const Flow& flow, double fraction, float sign) {
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const std::size_t i = std::size_t(y) * w + x;
        const float fu = flow.uv[2 * i], fv = flow.uv[2 * i + 1];
        const int tx = int(std::floor(x + 0.5 + fraction * fu));
        const int ty = int(std::floor(y + 0.5 + fraction * fv));
        if (tx < 0 || tx >= w || ty < 0 || ty >= h) continue;
        const std::size_t t = std::size_t(ty) * w + tx;
        const float k = splat_key(flow.valid[i] != 0, fu, fv);
        if (k <= key[t]) continue;
        key[t] = k, uv[2 * t] = sign * fu, uv[2 * t + 1] = sign * fv;
      }
  };
  splat(flows.forward, alpha, 1.0f);
  splat(flows.backward, 1.0 - alpha, -1.0f);

  // Holes, outside in: each ring takes the mean of its already filled 4-neighbours.
  std::vector<std::size_t> ring;
  std::vector<float> ring_uv;
  for (;;) {
    ring.clear(), ring_uv.clear();
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const std::size_t i = std::size_t(y) * w + x;
        if (key[i] > 0) continue;
        float su = 0, sv = 0;
        int n = 0;
        const auto take = [&](int nx, int ny) {
          if (nx < 0 || nx >= w || ny < 0 || ny >= h) return;
          const std::size_t j = std::size_t(ny) * w + nx;
          if (key[j] <= 0) return;
          su += uv[2 * j], sv += uv[2 * j + 1], ++n;
        };
        take(x - 1, y), take(x + 1, y), take(x, y - 1), take(x, y + 1);
        if (n == 0) continue;
        ring.push_back(i), ring_uv.push_back(su / n), ring_uv.push_back(sv / n);
      }
    if (ring.empty()) break;  // filled, or nothing landed at all (zero motion stays)
    for (std::size_t r = 0; r < ring.size(); ++r) {
      const std::size_t i = ring[r];
      uv[2 * i] = ring_uv[2 * r], uv[2 * i + 1] = ring_uv[2 * r + 1], key[i] = 0.25f;
    }
  }
  return uv;
}

// Whether continuous position (px, py) (pixel centres at +0.5) lies in the image, and the pixel.
bool pixel_at(const Flow& flow, double px, double py, std::size_t& index) {
  if (!(px >= 0 && px < flow.width && py >= 0 && py < flow.height)) return false;
  index = std::size_t(py) * flow.width + std::size_t(px);
  return true;
}

}  // namespace

Image interpolate_flow(const Image& a, const Image& b, const prepare::FlowPair& flows,
                       double alpha) {
  check_image_pair(a, b, "interpolate_flow");
  for (const Flow* f : {&flows.forward, &flows.backward})
    if (f->width != a.width || f->height != a.height)
      fail("interpolate_flow: flow is {}x{} but the images are {}x{}", f->width, f->height, a.width,
           a.height);
  if (!(alpha >= 0 && alpha <= 1)) fail("interpolate_flow: alpha {} is outside [0, 1]", alpha);
  if (alpha == 0) return a;
  if (alpha == 1) return b;

  const std::vector<float> uv = flow_at_time(flows, alpha);
  Image out(a.width, a.height, a.channels);
  const int channels = a.channels;
  parallel_for(std::size_t(a.height), [&](std::size_t row) {
    const int y = int(row);
    for (int x = 0; x < a.width; ++x) {
      const std::size_t i = std::size_t(y) * a.width + x;
      const double u = uv[2 * i], v = uv[2 * i + 1];
      const double ax = x + 0.5 - alpha * u, ay = y + 0.5 - alpha * v;
      const double bx = x + 0.5 + (1 - alpha) * u, by = y + 0.5 + (1 - alpha) * v;
      std::size_t ia = 0, ib = 0;
      const bool in_a = pixel_at(flows.forward, ax, ay, ia);
      const bool in_b = pixel_at(flows.backward, bx, by, ib);
      // Seen in a unless b's pixel is hidden in a (fails its check), and likewise for b.
      const bool seen_a = in_a && (!in_b || flows.backward.valid[ib]);
      const bool seen_b = in_b && (!in_a || flows.forward.valid[ia]);
      const double wa = (1 - alpha) * seen_a, wb = alpha * seen_b;
      float* o = out.pixel(y, x);
      if (wa + wb == 0) {
        const float *pa = a.pixel(y, x), *pb = b.pixel(y, x);
        for (int c = 0; c < channels; ++c) o[c] = float((1 - alpha) * pa[c] + alpha * pb[c]);
        continue;
      }
      for (int c = 0; c < channels; ++c) {
        const double sa = wa > 0 ? sample_bilinear(a, ax, ay, c) : 0.0;
        const double sb = wb > 0 ? sample_bilinear(b, bx, by, c) : 0.0;
        o[c] = float((wa * sa + wb * sb) / (wa + wb));
      }
    }
  });
  return out;
}

prepare::FlowPair flow_pair(const io::Scene& scene, int camera, int a, int b, const Image& image_a,
                            const Image& image_b) {
  std::optional<Flow> forward = io::load_flow(scene, camera, a, b);
  std::optional<Flow> backward = io::load_flow(scene, camera, b, a);
  if (!forward || !backward) return prepare::estimate_flow_pair(image_a, image_b);
  prepare::FlowPair pair{*forward, *backward};
  prepare::mark_inconsistent(pair.forward, *backward);
  prepare::mark_inconsistent(pair.backward, *forward);
  return pair;
}

}  // namespace retimegs::eval
