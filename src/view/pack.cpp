#include "retimegs/view/pack.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include <nlohmann/json.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/core/interrupt.hpp"
#include "retimegs/media/scene_images.hpp"
#include "retimegs/model/sh.hpp"
#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/playback/render_model.hpp"

namespace retimegs::view {

std::uint16_t half_from_float(float value) {
  const std::uint32_t bits = std::bit_cast<std::uint32_t>(value);
  const std::uint16_t sign = std::uint16_t((bits >> 16) & 0x8000u);
  const std::uint32_t abs = bits & 0x7fffffffu;
  if (abs >= 0x7f800000u) return std::uint16_t(sign | 0x7c00u | (abs > 0x7f800000u ? 0x200u : 0));
  if (abs >= 0x477ff000u) return std::uint16_t(sign | 0x7c00u);  // rounds past 65504: infinity
  if (abs < 0x38800000u) {
    // Subnormal half (or zero): the value in units of 2^-24, rounded to nearest even.
    if (abs < 0x33000000u) return sign;  // below half of the smallest subnormal
    const std::uint32_t mantissa = (abs & 0x7fffffu) | 0x800000u;
    const int shift = 126 - int(abs >> 23);  // 14 + (113 - exponent)
    const std::uint32_t rounded = mantissa >> shift;
    const std::uint32_t rest = mantissa & ((1u << shift) - 1), halfway = 1u << (shift - 1);
    return std::uint16_t(sign | (rounded + (rest > halfway || (rest == halfway && (rounded & 1)))));
  }
  // Normal: rebias the exponent (127 -> 15) and round the 23-bit mantissa to 10 bits.
  const std::uint32_t rebiased = abs - 0x38000000u;
  const std::uint32_t rounded = rebiased >> 13, rest = rebiased & 0x1fffu;
  return std::uint16_t(sign | (rounded + (rest > 0x1000u || (rest == 0x1000u && (rounded & 1)))));
}

float float_from_half(std::uint16_t half) {
  const std::uint32_t sign = std::uint32_t(half & 0x8000u) << 16;
  const std::uint32_t exponent = (half >> 10) & 0x1fu, mantissa = half & 0x3ffu;
  if (exponent == 0) {
    const float value = std::ldexp(float(mantissa), -24);
    return sign ? -value : value;
  }
  if (exponent == 31) return std::bit_cast<float>(sign | 0x7f800000u | (mantissa << 13));
  return std::bit_cast<float>(sign | ((exponent + 112) << 23) | (mantissa << 13));
}

namespace {

constexpr float kMaxHalf = 65504.0f;

// Appends one texture, zero-padded to whole rows; `texel(i, k, rgba)` fills texel k of primitive i.
template <typename Fill>
void add_texture(Packed& packed, const std::string& name, bool half, int texels_per_primitive,
                 std::size_t count, Fill texel) {
  const std::size_t texels = std::max<std::size_t>(count * texels_per_primitive, 1);
  const std::size_t rows = (texels + kTextureWidth - 1) / kTextureWidth;
  const std::size_t bytes = rows * kTextureWidth * 4 * (half ? 2 : 4);
  PackedTexture t{name, half, texels_per_primitive, int(rows), packed.data.size(), bytes};
  packed.data.resize(packed.data.size() + bytes, 0);
  std::uint8_t* out = packed.data.data() + t.offset;
  float rgba[4];
  for (std::size_t i = 0; i < count; ++i) {
    throw_if_interrupted_every(i);
    for (int k = 0; k < texels_per_primitive; ++k) {
      std::fill_n(rgba, 4, 0.0f);
      texel(i, k, rgba);
      const std::size_t at = (i * texels_per_primitive + k) * 4;
      for (int c = 0; c < 4; ++c) {
        if (half) {
          if (!(std::abs(rgba[c]) <= kMaxHalf))
            fail("view: {} of primitive {} is {}, beyond a half float's range (+-65504)", name, i,
                 double(rgba[c]));
          const std::uint16_t h = half_from_float(rgba[c]);
          std::memcpy(out + 2 * (at + c), &h, 2);
        } else {
          std::memcpy(out + 4 * (at + c), &rgba[c], 4);
        }
      }
    }
  }
  packed.textures.push_back(t);
}

// Where the viewer looks without a scene camera: the primitives' per-axis median and the 80th
// percentile of their distance from it (robust to the few far-flung background splats).
void framing(const model::Primitives& p, double centre[3], double& radius) {
  const std::size_t n = p.size();
  radius = 1;
  centre[0] = centre[1] = centre[2] = 0;
  if (n == 0) return;
  std::vector<float> values(n);
  for (int a = 0; a < 3; ++a) {
    for (std::size_t i = 0; i < n; ++i) values[i] = p.mu[3 * i + a];
    std::nth_element(values.begin(), values.begin() + n / 2, values.end());
    centre[a] = values[n / 2];
  }
  for (std::size_t i = 0; i < n; ++i) {
    const double dx = p.mu[3 * i] - centre[0], dy = p.mu[3 * i + 1] - centre[1],
                 dz = p.mu[3 * i + 2] - centre[2];
    values[i] = float(std::sqrt(dx * dx + dy * dy + dz * dz));
  }
  const std::size_t k = std::min(n - 1, n * 8 / 10);
  std::nth_element(values.begin(), values.begin() + k, values.end());
  radius = std::max(double(values[k]), 1e-3);
}

}  // namespace

Packed pack(const model::Model& model, const PackScene& pack_scene) {
  const model::Primitives& p = model.primitives;
  model::check_primitives(p, "view");
  const std::size_t n = p.size();
  const int degree = std::clamp(model.config.sh_degree, 0, model::kMaxShDegree);
  const int sh_values = 3 * model::sh_coeffs(degree);
  const int sh_texels = (sh_values + 3) / 4;
  constexpr int kSh = model::Primitives::kShWidth;

  Packed packed;
  // Positions and times in float32: they are the model's own values, and a half float's 11 bits
  // would move a point by 1/2048 of its distance from the origin and a window edge by up to 1/16
  // frame at t ~ 100.
  add_texture(packed, "mu", false, 1, n, [&](std::size_t i, int, float* t) {
    std::copy_n(&p.mu[3 * i], 3, t), t[3] = p.mu_tau[i];
  });
  const float* trailing[3] = {p.tau_l.data(), p.tau_r.data(), p.temporal_log_scale.data()};
  for (int j = 0; j < 3; ++j)
    add_texture(packed, "v" + std::to_string(j + 1), false, 1, n,
                [&](std::size_t i, int, float* t) {
                  std::copy_n(&p.velocity[9 * i + 3 * j], 3, t), t[3] = trailing[j][i];
                });
  // Shape, rotation and colour in half floats: 11 significant bits change a scale by < 0.05 %, a
  // rotation by < 0.1 degree and a colour by < 1/2000, below one 8-bit step.
  add_texture(packed, "shape", true, 1, n, [&](std::size_t i, int, float* t) {
    std::copy_n(&p.log_scale[3 * i], 3, t), t[3] = p.opacity_logit[i];
  });
  add_texture(packed, "q0", true, 1, n,
              [&](std::size_t i, int, float* t) { std::copy_n(&p.q0[4 * i], 4, t); });
  add_texture(packed, "q1", true, 1, n,
              [&](std::size_t i, int, float* t) { std::copy_n(&p.q1[4 * i], 4, t); });
  add_texture(packed, "sh", true, sh_texels, n, [&](std::size_t i, int k, float* t) {
    for (int c = 0; c < 4 && 4 * k + c < sh_values; ++c) t[c] = p.sh[kSh * i + 4 * k + c];
  });

  using nlohmann::json;
  json m;
  m["format"] = "retimegs-web";
  m["version"] = 1;
  m["count"] = n;
  m["texture_width"] = kTextureWidth;
  json textures = json::array();
  for (const PackedTexture& t : packed.textures)
    textures.push_back({{"name", t.name},
                        {"type", t.half ? "rgba16f" : "rgba32f"},
                        {"texels_per_primitive", t.texels_per_primitive},
                        {"height", t.height},
                        {"offset", t.offset},
                        {"bytes", t.bytes}});
  m["textures"] = textures;
  const bool stgs = model.config.representation == model::Representation::kStgs;
  m["representation"] = stgs ? "stgs" : "retime";
  m["trajectory"] =
      model.config.trajectory == model::TrajectoryKind::kLinear ? "linear" : "catmull_rom";
  m["time"] = {{"first", model.grid.first},
               {"step", model.grid.step},
               {"count", model.grid.count},
               {"last", model.grid.last()}};
  json training = json::array();
  for (int i = 0; i < model.grid.count; ++i) training.push_back(model.grid.at(i));
  m["training_frames"] = training;
  m["gamma_frames"] = model.grid.to_frames(model.config.gamma);
  m["epsilon"] = model.config.epsilon;
  json seams = json::array();
  for (const int seam : model.config.seams) seams.push_back(model.grid.at(seam));
  m["seams"] = seams;
  m["seam_scale_frames"] = model::seam_scale_frames(model.config, model.grid);
  m["handover_tail"] = model::kHandoverTail;  // the viewer's seam_handover reads it here
  m["sh_degree"] = degree;
  m["min_opacity"] = 1.0 / 255.0;
  double centre[3], radius;
  framing(p, centre, radius);
  m["center"] = {centre[0], centre[1], centre[2]};
  m["radius"] = radius;
  m["background"] = {0, 0, 0};  // retimegs render's default --background
  m["near"] = pack_scene.near_plane;
  json cameras = json::array();
  if (const io::Scene* scene = pack_scene.scene) {
    m["fps"] = scene->fps;
    m["num_frames"] = scene->num_frames;
    m["up"] = {scene->up[0], scene->up[1], scene->up[2]};
    for (const Camera& scene_camera : scene->cameras) {
      // As the model saw it (a training camera through its pose correction): snapping to a
      // camera reproduces its frames, as `render --camera` does.
      const Camera c = model::seen_camera(model, scene_camera);
      json w2c = json::array();
      for (int r = 0; r < 4; ++r)
        for (int k = 0; k < 4; ++k) w2c.push_back(c.world_to_camera(r, k));
      json cam = {{"name", c.name},
                  {"width", c.width},
                  {"height", c.height},
                  {"fx", c.fx},
                  {"fy", c.fy},
                  {"cx", c.cx},
                  {"cy", c.cy},
                  {"world_to_camera", w2c},
                  {"split", c.split == Split::kTrain ? "train" : "test"}};
      if (const model::CameraColor* color = model::find_camera_color(model, c.name))
        cam["color"] = {{"m", color->m}, {"c", color->c}};
      cameras.push_back(cam);
    }
  } else {
    m["up"] = {0, -1, 0};  // io::Scene's default: OpenCV's y points down
  }
  m["cameras"] = cameras;
  packed.manifest = m.dump(1);
  return packed;
}

Packed pack_for_web(const std::filesystem::path& model_path,
                    const std::filesystem::path& scene_path, const std::optional<double>& near) {
  const model::Model model = playback::read_4d_model(model_path);
  std::optional<io::Scene> scene;
  PackScene pack_scene;
  if (!scene_path.empty()) {
    scene = media::read_scene(scene_path, media::SceneCheck::kJson);
    pack_scene.scene = &*scene;
    pack_scene.near_plane = playback::near_plane(near, *scene);
  } else if (near) {
    pack_scene.near_plane = playback::near_plane(near, io::Scene{});
  }
  return pack(model, pack_scene);
}

}  // namespace retimegs::view
