// The reference rasteriser: per pixel, all Gaussians sorted by depth, double precision.
#include "retimegs/render/reference.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "retimegs/core/error.hpp"
#include "retimegs/render/rasterize.hpp"

namespace retimegs::render {
namespace {

// One Gaussian composited into one pixel.
struct Contribution {
  std::int32_t gaussian;
  double dx, dy;     // mean2d - pixel centre
  double gauss;      // exp(-sigma)
  double alpha_raw;  // opacity * gauss
  double alpha;      // min(alpha_clamp, alpha_raw)
  double t;          // transmittance in front of it
};

struct Scene {
  int width, height, channels, channels_ext, tiles_x, tiles_y;
  ProjectedT<double> projected;
  std::vector<std::int32_t> depth_order;  // [V] visible Gaussians, front to back
  std::vector<TileRect> rects;            // [N]
  std::vector<double> background;         // [C'] (depth composites over 0)
};

Scene prepare(const ProjectedT<double>& projected, const GaussiansT<double>& g, int width,
              int height, const double* background, const RenderOptions& options) {
  if (projected.size() != g.size())
    fail("reference: {} projected Gaussians for a batch of {}", projected.size(), g.size());
  Scene s;
  s.width = width;
  s.height = height;
  s.channels = g.channels;
  s.channels_ext = g.channels + (options.render_depth ? 1 : 0);
  s.tiles_x = tile_count(s.width);
  s.tiles_y = tile_count(s.height);
  s.projected = projected;
  s.rects.resize(g.size());
  for (std::size_t i = 0; i < g.size(); ++i) {
    if (s.projected.radii[i] <= 0) continue;
    s.rects[i] =
        blend_tile_rect(&s.projected.means2d[2 * i], &s.projected.conics[3 * i],
                        s.projected.radii[i], g.opacities[i], s.tiles_x, s.tiles_y, options);
    if (s.rects[i].area() > 0) s.depth_order.push_back(std::int32_t(i));
  }
  std::stable_sort(s.depth_order.begin(), s.depth_order.end(), [&](std::int32_t a, std::int32_t b) {
    return s.projected.depths[a] < s.projected.depths[b];
  });
  s.background.assign(s.channels_ext, 0.0);
  if (background) std::copy(background, background + s.channels, s.background.begin());
  return s;
}

double feature(const GaussiansT<double>& g, const Scene& s, std::int32_t i, int c) {
  return c < s.channels ? g.features[std::size_t(i) * s.channels + c] : s.projected.depths[i];
}

// Front-to-back compositing of pixel (row y, column x): the Gaussians composited and the
// transmittance left.
double composite_pixel(const GaussiansT<double>& g, const Scene& s, const RenderOptions& options,
                       int x, int y, std::vector<Contribution>& contributions) {
  contributions.clear();
  const double px = x + 0.5, py = y + 0.5;
  const int tx = x / kTileSize, ty = y / kTileSize;
  double t = 1.0;
  for (const std::int32_t i : s.depth_order) {
    if (!s.rects[i].contains(tx, ty)) continue;
    const double* conic = &s.projected.conics[3 * i];
    const double dx = s.projected.means2d[2 * i] - px, dy = s.projected.means2d[2 * i + 1] - py;
    const double sigma = 0.5 * (conic[0] * dx * dx + conic[2] * dy * dy) + conic[1] * dx * dy;
    const double gauss = std::exp(-sigma);
    const double alpha_raw = g.opacities[i] * gauss;
    const double alpha = std::min(double(options.alpha_clamp), alpha_raw);
    if (alpha < double(options.min_alpha)) continue;
    const double next_t = t * (1 - alpha);
    const bool stop = options.stop_rule == StopRule::kAtOrBelow
                          ? next_t <= double(options.min_transmittance)
                          : next_t < double(options.min_transmittance);
    if (stop) break;
    contributions.push_back({i, dx, dy, gauss, alpha_raw, alpha, t});
    t = next_t;
  }
  return t;
}

}  // namespace

ReferenceOutput reference_blend_forward(const ProjectedT<double>& projected,
                                        const GaussiansT<double>& g, int width, int height,
                                        const double* background, const RenderOptions& options) {
  const Scene s = prepare(projected, g, width, height, background, options);
  ReferenceOutput out;
  out.width = s.width;
  out.height = s.height;
  out.channels = s.channels;
  const std::size_t pixels = std::size_t(s.width) * s.height;
  out.image.assign(pixels * s.channels, 0.0);
  out.alpha.assign(pixels, 0.0);
  out.final_T.assign(pixels, 0.0);
  out.n_contrib.assign(pixels, 0);
  if (options.render_depth) out.depth.assign(pixels, 0.0);
  std::vector<Contribution> contributions;
  std::vector<double> sum(s.channels_ext);
  for (int y = 0; y < s.height; ++y)
    for (int x = 0; x < s.width; ++x) {
      const double t_final = composite_pixel(g, s, options, x, y, contributions);
      std::fill(sum.begin(), sum.end(), 0.0);
      for (const Contribution& k : contributions)
        for (int c = 0; c < s.channels_ext; ++c)
          sum[c] += feature(g, s, k.gaussian, c) * k.alpha * k.t;
      const std::size_t pixel = std::size_t(y) * s.width + x;
      for (int c = 0; c < s.channels; ++c)
        out.image[pixel * s.channels + c] = sum[c] + t_final * s.background[c];
      if (options.render_depth) out.depth[pixel] = sum[s.channels];
      out.final_T[pixel] = t_final;
      out.alpha[pixel] = 1 - t_final;
      out.n_contrib[pixel] = std::int32_t(contributions.size());
    }
  out.projected = s.projected;
  return out;
}

void reference_blend_backward(const ProjectedT<double>& projected, const GaussiansT<double>& g,
                              int width, int height, const double* background,
                              const RenderOptions& options, const double* v_image,
                              const double* v_alpha, const double* v_depth,
                              GaussianGradsT<double>& grads) {
  if (!v_image) fail("reference_blend_backward: v_image is required");
  const Scene s = prepare(projected, g, width, height, background, options);
  const std::size_t n = g.size();
  grads.channels = g.channels;
  grads.v_means2d.assign(2 * n, 0.0);
  grads.v_conics.assign(3 * n, 0.0);
  grads.v_opacities.assign(n, 0.0);
  grads.v_features.assign(n * g.channels, 0.0);
  grads.v_depths.assign(n, 0.0);
  std::vector<Contribution> contributions;
  std::vector<double> v_out(s.channels_ext), behind(s.channels_ext);
  for (int y = 0; y < s.height; ++y)
    for (int x = 0; x < s.width; ++x) {
      const std::size_t pixel = std::size_t(y) * s.width + x;
      const double t_final = composite_pixel(g, s, options, x, y, contributions);
      for (int c = 0; c < s.channels; ++c) v_out[c] = v_image[pixel * s.channels + c];
      if (options.render_depth) v_out[s.channels] = v_depth ? v_depth[pixel] : 0.0;
      const double v_alpha_out = v_alpha ? v_alpha[pixel] : 0.0;
      // behind[c] = what the Gaussians behind the current one (and the background) add.
      for (int c = 0; c < s.channels_ext; ++c) behind[c] = t_final * s.background[c];
      for (auto k = contributions.rbegin(); k != contributions.rend(); ++k) {
        const std::int32_t i = k->gaussian;
        // out_c = ... + f_c alpha T + behind_c, where behind_c carries a factor (1 - alpha);
        // alpha_out = 1 - T_final, T_final carries a factor (1 - alpha).
        double v_a = v_alpha_out * t_final / (1 - k->alpha);
        for (int c = 0; c < s.channels_ext; ++c) {
          const double f = feature(g, s, i, c);
          v_a += v_out[c] * (f * k->t - behind[c] / (1 - k->alpha));
          const double v_f = k->alpha * k->t * v_out[c];
          if (c < s.channels) {
            grads.v_features[std::size_t(i) * s.channels + c] += v_f;
          } else {
            grads.v_depths[i] += v_f;
          }
          behind[c] += f * k->alpha * k->t;
        }
        if (k->alpha_raw > double(options.alpha_clamp)) continue;  // clamped: no gradient
        grads.v_opacities[i] += k->gauss * v_a;
        const double v_sigma = -k->alpha * v_a;
        const double* conic = &s.projected.conics[3 * i];
        grads.v_conics[3 * i] += 0.5 * k->dx * k->dx * v_sigma;
        grads.v_conics[3 * i + 1] += k->dx * k->dy * v_sigma;
        grads.v_conics[3 * i + 2] += 0.5 * k->dy * k->dy * v_sigma;
        grads.v_means2d[2 * i] += (conic[0] * k->dx + conic[1] * k->dy) * v_sigma;
        grads.v_means2d[2 * i + 1] += (conic[1] * k->dx + conic[2] * k->dy) * v_sigma;
      }
    }
}

ReferenceOutput reference_forward(const GaussiansT<double>& g, const Camera& camera,
                                  const double* background, const RenderOptions& options) {
  check_camera(camera);  // project_forward validates the Gaussians
  return reference_blend_forward(project_forward(g, PinholeT<double>(camera), options), g,
                                 camera.width, camera.height, background, options);
}

GaussianGradsT<double> reference_backward(const GaussiansT<double>& g, const Camera& camera,
                                          const double* background, const RenderOptions& options,
                                          const double* v_image, const double* v_alpha,
                                          const double* v_depth) {
  check_camera(camera);  // project_forward validates the Gaussians
  const PinholeT<double> pinhole(camera);
  const ProjectedT<double> projected = project_forward(g, pinhole, options);
  GaussianGradsT<double> grads(g.size(), g.channels);
  reference_blend_backward(projected, g, camera.width, camera.height, background, options, v_image,
                           v_alpha, v_depth, grads);
  project_backward(g, pinhole, projected, options, grads);
  return grads;
}

}  // namespace retimegs::render
