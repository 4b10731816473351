// WebGL2 renderer of the packed model. Pass 1 evaluates each primitive at time t once per frame
// (a vertex shader over points, its results captured by transform feedback) exactly as
// model::slice does (window, trajectory, rotation, SH) and
// projected as render/project.cpp does (EWA with the field-of-view guard, 0.3 px² low-pass, near
// plane, pixel centres at +0.5); pass 2 draws one instanced quad per primitive from those
// records, composited back to front with premultiplied alpha: the same
// sum as the CPU renderer's front-to-back blend (alpha = min(0.99, opacity · G), skipped below
// 1/255). Pass 2 composites into an offscreen image; near a merged model's seam into two, one per
// side of the seam (time_model.js imagesAt, model::seam_handover), and a final pass mixes them by
// their weights, as playback::ModelRenderer::draw does, and applies the colour map.
import { imagesAt, timeSettings } from './time_model.js';

// Pass 1, per primitive (points, rasteriser off): the Gaussian at time t in image space.
const PREPARE_SHADER = `#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;

uniform sampler2D u_mu, u_v1, u_v2, u_v3, u_shape, u_q0, u_q1, u_sh;
uniform int u_width_texels;   // texels per texture row
uniform int u_sh_texels;      // SH texels per primitive
uniform int u_sh_degree;
uniform int u_representation; // 0 RetimeGS, 1 STGS
uniform int u_linear;         // 1: the linear trajectory ablation
uniform float u_t, u_step, u_first, u_last, u_gamma, u_epsilon, u_min_opacity;
// A merged model's seams (times, four to a vector: core/limits.hpp kMaxSeams = 255 fit in 64) and
// their edge scale: time_model.js edgeScale.
uniform vec4 u_seams[64];
uniform int u_seam_count;
uniform float u_seam_scale;
// The side of the seam at u_side_seam (frames) this image draws: -1 before, 1 after, 0 neither
// (time_model.js SIDE_*, model::SeamSide).
uniform int u_side;
uniform float u_side_seam;
uniform mat3 u_rotation;      // world to camera (OpenCV), column-major as GLSL stores it
uniform vec3 u_translation;
uniform vec4 u_intrinsics;    // fx, fy, cx, cy (pixels)
uniform vec2 u_size;          // image width, height (pixels)
uniform vec3 u_eye;           // camera centre (world)
uniform float u_near, u_low_pass, u_fov_guard;
uniform vec3 u_gain, u_offset;  // the camera's colour map: gain · rgb + offset

in uint a_index;

// One record per primitive, captured by transform feedback (culled: opacity 0).
out vec4 f_centre;  // projected centre (pixels), opacity σ·σ_τ(t), unused
out vec4 f_axes;    // the quad's half-axes (pixels): a1, a2
out vec4 f_conic;   // inverse 2-D covariance (a, b, c), unused
out vec4 f_color;   // RGB through the camera's colour map, unused

ivec2 texel(int k) { return ivec2(k % u_width_texels, k / u_width_texels); }
float sigmoid(float x) { return 1.0 / (1.0 + exp(-x)); }
float edge_scale(float edge) {
  for (int k = 0; k < u_seam_count; ++k)
    if (abs(edge - u_seams[k / 4][k % 4]) <= u_epsilon) return u_seam_scale;
  return u_gamma;
}
bool at_side_seam(float edge) { return u_side != 0 && abs(edge - u_side_seam) <= u_epsilon; }

const float SH_C0 = 0.28209479177387814;
const float SH_C1 = 0.4886025119029199;
const float SH_C2[5] = float[5](1.0925484305920792, -1.0925484305920792, 0.31539156525252005,
                                -1.0925484305920792, 0.5462742152960396);
const float SH_C3[7] = float[7](-0.5900435899266435, 2.890611442640554, -0.4570457994644658,
                                0.3731763325901154, -0.4570457994644658, 1.445305721320277,
                                -0.5900435899266435);

// The primitive's SH values, fetched once per vertex: 3K values in ceil(3K/4) texels.
vec4 sh_texels[12];
void fetch_sh(int i) {
  for (int k = 0; k < 12; ++k)
    if (k < u_sh_texels) sh_texels[k] = texelFetch(u_sh, texel(i * u_sh_texels + k), 0);
}

// Coefficient k (RGB): values 3k..3k+2.
vec3 sh_coefficient(int i, int k) {
  vec3 c;
  for (int a = 0; a < 3; ++a) {
    int v = 3 * k + a;
    c[a] = sh_texels[v / 4][v % 4];
  }
  return c;
}

// model/sh.cpp: colour = max(Σ b_k(d) h_k + 0.5, 0) at the unit direction d.
vec3 sh_color(int i, vec3 dir) {
  float len = length(dir);
  vec3 d = len > 0.0 ? dir / len : vec3(0.0);
  float x = d.x, y = d.y, z = d.z;
  vec3 c = SH_C0 * sh_coefficient(i, 0);
  if (u_sh_degree >= 1) {
    c += -SH_C1 * y * sh_coefficient(i, 1) + SH_C1 * z * sh_coefficient(i, 2) -
         SH_C1 * x * sh_coefficient(i, 3);
  }
  if (u_sh_degree >= 2) {
    float xx = x * x, yy = y * y, zz = z * z;
    c += SH_C2[0] * x * y * sh_coefficient(i, 4) + SH_C2[1] * y * z * sh_coefficient(i, 5) +
         SH_C2[2] * (2.0 * zz - xx - yy) * sh_coefficient(i, 6) +
         SH_C2[3] * x * z * sh_coefficient(i, 7) + SH_C2[4] * (xx - yy) * sh_coefficient(i, 8);
    if (u_sh_degree >= 3) {
      c += SH_C3[0] * y * (3.0 * xx - yy) * sh_coefficient(i, 9) +
           SH_C3[1] * x * y * z * sh_coefficient(i, 10) +
           SH_C3[2] * y * (4.0 * zz - xx - yy) * sh_coefficient(i, 11) +
           SH_C3[3] * z * (2.0 * zz - 3.0 * xx - 3.0 * yy) * sh_coefficient(i, 12) +
           SH_C3[4] * x * (4.0 * zz - xx - yy) * sh_coefficient(i, 13) +
           SH_C3[5] * z * (xx - yy) * sh_coefficient(i, 14) +
           SH_C3[6] * x * (xx - 3.0 * yy) * sh_coefficient(i, 15);
    }
  }
  return max(c + 0.5, 0.0);
}

// Rotation matrix of a unit quaternion (w, x, y, z), as columns for GLSL.
mat3 quat_to_rotation(vec4 q) {
  float w = q.x, x = q.y, y = q.z, z = q.w;
  return mat3(1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + w * z), 2.0 * (x * z - w * y),
              2.0 * (x * y - w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z + w * x),
              2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y));
}

void cull() {
  f_centre = vec4(0.0);
  f_axes = vec4(0.0);
  f_conic = vec4(0.0);
  f_color = vec4(0.0);
}

void main() {
  int i = int(a_index);
  ivec2 at = texel(i);
  vec4 mu = texelFetch(u_mu, at, 0);   // μ, μ_τ
  vec4 v1 = texelFetch(u_v1, at, 0);   // v1, τ_l
  vec4 v2 = texelFetch(u_v2, at, 0);   // v2, τ_r
  vec4 v3 = texelFetch(u_v3, at, 0);   // v3, STGS temporal log-scale
  vec4 shape = texelFetch(u_shape, at, 0);  // log-scale, opacity logit
  float mu_tau = mu.w, t = u_t;

  // Temporal opacity σ_τ(t) (RetimeWindow, or the STGS Gaussian window). Drawn for one side of a
  // seam, an edge at that seam is open, and a primitive that starts (before) or ends (after)
  // there belongs to the other side: time_model.js temporalOpacity.
  float window;
  if (u_representation == 1) {
    float d = (t - mu_tau) * exp(-v3.w);
    window = exp(-d * d);
  } else {
    float a = mu_tau - v1.w, b = mu_tau + v2.w;
    bool open_left = a <= u_first + u_epsilon;
    bool open_right = b >= u_last - u_epsilon;
    bool at_left = at_side_seam(a), at_right = at_side_seam(b);
    if ((u_side == -1 && !open_left && at_left) || (u_side == 1 && !open_right && at_right)) {
      cull();
      return;
    }
    float left = open_left || at_left ? 1.0 : sigmoid((t - a) / edge_scale(a));
    float right = open_right || at_right ? 1.0 : sigmoid((b - t) / edge_scale(b));
    window = left * right;
  }
  float opacity = sigmoid(shape.w) * window;
  if (opacity < u_min_opacity) { cull(); return; }

  // Position x(t) = μ + c0 v1 + c1 v2 + c2 v3 (trajectory_at).
  vec3 c;
  if (u_representation == 1) {
    float d = t - mu_tau;
    c = vec3(d, d * d, d * d * d);
  } else if (u_linear == 1) {
    c = vec3(0.0, t - mu_tau, 0.0);
  } else {
    float u = (t - (mu_tau - u_step / 2.0)) / u_step;
    vec4 w;
    if (u < 0.0) {
      w = vec4(-u / 2.0, 1.0, u / 2.0, 0.0);
    } else if (u > 1.0) {
      w = vec4(0.0, -(u - 1.0) / 2.0, 1.0, (u - 1.0) / 2.0);
    } else {
      float u2 = u * u, u3 = u2 * u;
      w = vec4((-u + 2.0 * u2 - u3) / 2.0, (2.0 - 5.0 * u2 + 3.0 * u3) / 2.0,
               (u + 4.0 * u2 - 3.0 * u3) / 2.0, (-u2 + u3) / 2.0);
    }
    c = vec3(-u_step * w.x, u_step / 2.0 * (-w.x - w.y + w.z + w.w), u_step * w.w);
  }
  vec3 x = mu.xyz + c.x * v1.xyz + c.y * v2.xyz + c.z * v3.xyz;

  vec3 p = u_rotation * x + u_translation;
  if (!(p.z >= u_near)) { cull(); return; }

  // q(t) = normalize(q0 + q1 (t - μ_τ)); covariance R S Sᵀ Rᵀ.
  vec4 q = texelFetch(u_q0, at, 0) + texelFetch(u_q1, at, 0) * (t - mu_tau);
  float qn = length(q);
  if (!(qn > 0.0)) { cull(); return; }
  mat3 m = quat_to_rotation(q / qn) * mat3(exp(shape.x), 0.0, 0.0, 0.0, exp(shape.y), 0.0,
                                           0.0, 0.0, exp(shape.z));
  mat3 cov_cam = u_rotation * (m * transpose(m)) * transpose(u_rotation);

  // EWA: the Jacobian at the point clamped to the field-of-view guard (gsplat).
  float fx = u_intrinsics.x, fy = u_intrinsics.y, cx = u_intrinsics.z, cy = u_intrinsics.w;
  float tan_x = 0.5 * u_size.x / fx, tan_y = 0.5 * u_size.y / fy;
  float x_pos = (u_size.x - cx) / fx + u_fov_guard * tan_x;
  float x_neg = cx / fx + u_fov_guard * tan_x;
  float y_pos = (u_size.y - cy) / fy + u_fov_guard * tan_y;
  float y_neg = cy / fy + u_fov_guard * tan_y;
  float z = p.z;
  float txz = clamp(p.x / z, -x_neg, x_pos), tyz = clamp(p.y / z, -y_neg, y_pos);
  // J = [[fx/z, 0, -fx tx/z], [0, fy/z, -fy ty/z]]; GLSL mat3x2 is 3 columns of 2 rows.
  mat3x2 jac = mat3x2(fx / z, 0.0, 0.0, fy / z, -fx * txz / z, -fy * tyz / z);
  mat2 cov2d = jac * cov_cam * transpose(jac);
  float a = cov2d[0][0] + u_low_pass, b = cov2d[1][0], d = cov2d[1][1] + u_low_pass;
  float det = a * d - b * b;
  if (!(det > 0.0)) { cull(); return; }
  vec3 conic = vec3(d / det, -b / det, a / det);

  // The quad covers where opacity · exp(-σ) >= 1/255: σ <= level, along the covariance's axes.
  float level = log(opacity / u_min_opacity);
  if (!(level > 0.0)) { cull(); return; }
  float mid = 0.5 * (a + d), disc = sqrt(max(mid * mid - det, 0.0));
  float l1 = mid + disc, l2 = max(mid - disc, 0.0);
  vec2 e1 = abs(b) > 1e-12 * (a + d) ? normalize(vec2(b, l1 - a)) : (a >= d ? vec2(1, 0) : vec2(0, 1));
  vec2 e2 = vec2(-e1.y, e1.x);
  f_axes = vec4((sqrt(2.0 * level * l1) * 1.001 + 0.01) * e1,
                (sqrt(2.0 * level * l2) * 1.001 + 0.01) * e2);
  f_centre = vec4(fx * p.x / z + cx, fy * p.y / z + cy, opacity, 0.0);
  f_conic = vec4(conic, 0.0);
  fetch_sh(i);
  f_color = vec4(u_gain * sh_color(i, x - u_eye) + u_offset, 0.0);
}
`;

const NOTHING_SHADER = `#version 300 es
precision highp float;
out vec4 color;
void main() { color = vec4(0.0); }
`;

// Pass 2, six vertices (two triangles) per primitive: the quad over the ellipse where alpha >=
// 1/255, from the records of pass 1 (copied into a texture, 4 texels each). Not instanced:
// SwiftShader, the software WebGL2 of headless browsers, pays a draw call's set-up per instance.
const SPLAT_SHADER = `#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
uniform vec2 u_size;
uniform sampler2D u_records;
uniform int u_width_texels;
flat out vec3 v_color;
flat out float v_opacity;
flat out vec3 v_conic;
out vec2 v_offset;  // pixel offset from the projected centre
const int CORNER_X[6] = int[6](0, 1, 0, 0, 1, 1);
const int CORNER_Y[6] = int[6](0, 0, 1, 1, 0, 1);
vec4 record(int k) { return texelFetch(u_records, ivec2(k % u_width_texels, k / u_width_texels), 0); }
void main() {
  int splat = gl_VertexID / 6, vertex = gl_VertexID % 6;
  vec4 centre = record(4 * splat);
  if (!(centre.z > 0.0)) {
    gl_Position = vec4(0.0, 0.0, 2.0, 1.0);  // culled: outside the clip volume
    return;
  }
  vec4 axes = record(4 * splat + 1);
  vec2 corner = vec2(float(CORNER_X[vertex]), float(CORNER_Y[vertex])) * 2.0 - 1.0;
  vec2 offset = corner.x * axes.xy + corner.y * axes.zw;
  vec2 pixel = centre.xy + offset;
  gl_Position = vec4(2.0 * pixel.x / u_size.x - 1.0, 1.0 - 2.0 * pixel.y / u_size.y, 0.0, 1.0);
  v_offset = offset;
  v_conic = record(4 * splat + 2).xyz;
  v_opacity = centre.z;
  v_color = record(4 * splat + 3).rgb;
}
`;

const FRAGMENT_SHADER = `#version 300 es
precision highp float;
flat in vec3 v_color;
flat in float v_opacity;
flat in vec3 v_conic;
in vec2 v_offset;
uniform float u_min_opacity, u_alpha_clamp;
out vec4 color;
void main() {
  vec2 d = v_offset;
  float sigma = 0.5 * (v_conic.x * d.x * d.x + v_conic.z * d.y * d.y) + v_conic.y * d.x * d.y;
  float alpha = min(u_alpha_clamp, v_opacity * exp(-sigma));
  if (!(alpha >= u_min_opacity)) discard;
  color = vec4(v_color * alpha, alpha);
}
`;

// Final pass: the images of the two sides of a seam mixed, w · before + (1 - w) · after (one
// image: both samplers read it, w = 1), then the camera's colour map, after compositing as
// `render` applies it; the canvas clamps to [0, 1] as a PNG does.
const FULLSCREEN_SHADER = `#version 300 es
void main() {
  gl_Position = vec4(float((gl_VertexID & 1) * 4 - 1), float((gl_VertexID & 2) * 2 - 1), 0.0, 1.0);
}
`;
const MIX_SHADER = `#version 300 es
precision highp float;
uniform sampler2D u_before, u_after;
uniform float u_weight;
uniform vec3 u_gain, u_offset;
out vec4 color;
void main() {
  ivec2 at = ivec2(gl_FragCoord.xy);
  vec3 rgb = u_weight * texelFetch(u_before, at, 0).rgb +
             (1.0 - u_weight) * texelFetch(u_after, at, 0).rgb;
  color = vec4(u_gain * rgb + u_offset, 1.0);
}
`;

const RECORD_FLOATS = 16;  // f_centre, f_axes, f_conic, f_color

function compile(gl, type, source) {
  const shader = gl.createShader(type);
  gl.shaderSource(shader, source);
  gl.compileShader(shader);
  if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS))
    throw new Error(`shader: ${gl.getShaderInfoLog(shader)}`);
  return shader;
}

function link(gl, vertex, fragment, feedback) {
  const program = gl.createProgram();
  gl.attachShader(program, compile(gl, gl.VERTEX_SHADER, vertex));
  gl.attachShader(program, compile(gl, gl.FRAGMENT_SHADER, fragment));
  if (feedback) gl.transformFeedbackVaryings(program, feedback, gl.INTERLEAVED_ATTRIBS);
  gl.linkProgram(program);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS))
    throw new Error(`shader link: ${gl.getProgramInfoLog(program)}`);
  return program;
}

function uniformsOf(gl, program) {
  const uniforms = {};
  const count = gl.getProgramParameter(program, gl.ACTIVE_UNIFORMS);
  for (let k = 0; k < count; ++k) {
    const name = gl.getActiveUniform(program, k).name.replace(/\[0\]$/, '');
    uniforms[name] = gl.getUniformLocation(program, name);
  }
  return uniforms;
}

export class Renderer {
  // `textures`: {name: {data (Float32Array | Uint16Array), half, height, texelsPerPrimitive}}.
  constructor(gl, manifest, textures) {
    this.gl = gl;
    this.manifest = manifest;
    const program = link(gl, PREPARE_SHADER, NOTHING_SHADER,
                         ['f_centre', 'f_axes', 'f_conic', 'f_color']);
    this.program = program;
    this.splatProgram = link(gl, SPLAT_SHADER, FRAGMENT_SHADER, null);
    this.splatUniforms = uniformsOf(gl, this.splatProgram);
    gl.useProgram(program);
    this.uniforms = uniformsOf(gl, program);
    const maxSize = gl.getParameter(gl.MAX_TEXTURE_SIZE);
    const names = ['mu', 'v1', 'v2', 'v3', 'shape', 'q0', 'q1', 'sh'];
    names.forEach((name, unit) => {
      const t = textures[name];
      if (t.height > maxSize || manifest.texture_width > maxSize)
        throw new Error(`the model's ${name} texture needs ${manifest.texture_width}x${t.height} ` +
                        `texels; this GPU allows ${maxSize}x${maxSize}`);
      const texture = gl.createTexture();
      gl.activeTexture(gl.TEXTURE0 + unit);
      gl.bindTexture(gl.TEXTURE_2D, texture);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
      gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
      gl.texImage2D(gl.TEXTURE_2D, 0, t.half ? gl.RGBA16F : gl.RGBA32F, manifest.texture_width,
                    t.height, 0, gl.RGBA, t.half ? gl.HALF_FLOAT : gl.FLOAT, t.data);
      gl.uniform1i(this.uniforms[`u_${name}`], unit);
    });
    this.settings = timeSettings(manifest);
    const u = this.uniforms;
    gl.uniform1i(u.u_width_texels, manifest.texture_width);
    gl.uniform1i(u.u_sh_texels, textures.sh.texelsPerPrimitive);
    gl.uniform1i(u.u_sh_degree, manifest.sh_degree);
    gl.uniform1i(u.u_representation, manifest.representation === 'stgs' ? 1 : 0);
    gl.uniform1i(u.u_linear, manifest.trajectory === 'linear' ? 1 : 0);
    gl.uniform1f(u.u_step, manifest.time.step);
    gl.uniform1f(u.u_first, manifest.time.first);
    gl.uniform1f(u.u_last, manifest.time.last);
    gl.uniform1f(u.u_gamma, manifest.gamma_frames);
    gl.uniform1f(u.u_epsilon, manifest.epsilon);
    const packed = new Float32Array(4 * 64);
    packed.set(this.settings.seams);
    gl.uniform4fv(u.u_seams, packed);
    gl.uniform1i(u.u_seam_count, this.settings.seams.length);
    gl.uniform1f(u.u_seam_scale, this.settings.seamScale);
    gl.uniform1f(u.u_min_opacity, manifest.min_opacity);
    gl.uniform1f(u.u_low_pass, 0.3);      // render::RenderOptions::low_pass, px²
    gl.uniform1f(u.u_fov_guard, 0.3);     // render/constants.hpp kFovGuard
    gl.uniform1f(u.u_near, manifest.near);

    gl.useProgram(this.splatProgram);
    gl.uniform1f(this.splatUniforms.u_min_opacity, manifest.min_opacity);
    gl.uniform1f(this.splatUniforms.u_alpha_clamp, 0.99);  // render::RenderOptions::alpha_clamp

    // Pass 1 reads the sorted indices; pass 2 the records pass 1 wrote, one per instance.
    this.indexBuffer = gl.createBuffer();
    this.prepareVao = gl.createVertexArray();
    gl.bindVertexArray(this.prepareVao);
    gl.bindBuffer(gl.ARRAY_BUFFER, this.indexBuffer);
    const location = gl.getAttribLocation(program, 'a_index');
    gl.enableVertexAttribArray(location);
    gl.vertexAttribIPointer(location, 1, gl.UNSIGNED_INT, 0, 0);
    this.recordBuffer = gl.createBuffer();
    this.recordTexture = gl.createTexture();
    this.recordUnit = names.length;
    gl.activeTexture(gl.TEXTURE0 + this.recordUnit);
    gl.bindTexture(gl.TEXTURE_2D, this.recordTexture);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.useProgram(this.splatProgram);
    gl.uniform1i(this.splatUniforms.u_records, this.recordUnit);
    gl.uniform1i(this.splatUniforms.u_width_texels, manifest.texture_width);
    this.splatVao = gl.createVertexArray();
    gl.bindVertexArray(null);
    this.feedback = gl.createTransformFeedback();

    // Composite into half-float images where the GPU can (EXT_color_buffer_float): no 8-bit
    // rounding per blended splat, and the colour map applied to the result, not per splat.
    // Elsewhere into 8-bit images, the canvas's own precision, with the colour map per splat: a
    // seam's mix of two of them adds at most one rounding, half an 8-bit level, to each side's.
    this.halfFloat = gl.getExtension('EXT_color_buffer_float') !== null;
    this.mixProgram = link(gl, FULLSCREEN_SHADER, MIX_SHADER, null);
    this.mixUniforms = uniformsOf(gl, this.mixProgram);
    this.images = [1, 2].map((k) => ({ unit: this.recordUnit + k, texture: gl.createTexture(),
                                        framebuffer: gl.createFramebuffer() }));
    for (const image of this.images) {
      gl.activeTexture(gl.TEXTURE0 + image.unit);
      gl.bindTexture(gl.TEXTURE_2D, image.texture);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    }
    this.imageSize = [0, 0];
    this.instances = 0;
    this.capacity = 0;
  }

  // The draw order from the sort worker: indices back to front.
  setOrder(order) {
    const gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.indexBuffer);
    gl.bufferData(gl.ARRAY_BUFFER, order, gl.DYNAMIC_DRAW);
    this.instances = order.length;
    if (this.instances > this.capacity) {
      // Whole texture rows, so that the record texture takes the buffer as it is.
      const width = this.manifest.texture_width;
      this.recordRows = Math.ceil((4 * this.instances) / width);
      this.capacity = (this.recordRows * width) / 4;
      gl.bindBuffer(gl.ARRAY_BUFFER, this.recordBuffer);
      gl.bufferData(gl.ARRAY_BUFFER, this.capacity * RECORD_FLOATS * 4, gl.DYNAMIC_COPY);
      gl.activeTexture(gl.TEXTURE0 + this.recordUnit);
      gl.bindTexture(gl.TEXTURE_2D, this.recordTexture);
      gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, width, this.recordRows, 0, gl.RGBA, gl.FLOAT,
                    null);
    }
    gl.bindBuffer(gl.ARRAY_BUFFER, null);
  }

  // The offscreen images at the view's size.
  resizeImages(width, height) {
    const gl = this.gl;
    if (this.imageSize[0] === width && this.imageSize[1] === height) return;
    this.imageSize = [width, height];
    for (const image of this.images) {
      gl.activeTexture(gl.TEXTURE0 + image.unit);
      gl.bindTexture(gl.TEXTURE_2D, image.texture);
      const [format, type] = this.halfFloat ? [gl.RGBA16F, gl.HALF_FLOAT]
                                            : [gl.RGBA8, gl.UNSIGNED_BYTE];
      gl.texImage2D(gl.TEXTURE_2D, 0, format, width, height, 0, gl.RGBA, type, null);
      gl.bindFramebuffer(gl.FRAMEBUFFER, image.framebuffer);
      gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, image.texture,
                              0);
    }
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  }

  // view: {rotation [9] row-major world to camera, translation [3], fx, fy, cx, cy, width,
  // height, eye [3], color {m, c} or null}; background [3].
  draw(view, t, background) {
    const gl = this.gl, u = this.uniforms;
    gl.viewport(0, 0, view.width, view.height);
    this.resizeImages(view.width, view.height);
    const mapGain = view.color ? view.color.m.map(Math.exp) : [1, 1, 1];
    const mapOffset = view.color ? view.color.c : [0, 0, 0];
    // In 8-bit images the colour map goes with every splat's colour and the background: it is
    // affine and the blend weights (Σ αT plus the transmittance left) sum to one, so that maps
    // the image (up to the 8-bit clamping of each step); so does a seam's mix, whose weights sum
    // to one too.
    const [gain, offset] = this.halfFloat ? [[1, 1, 1], [0, 0, 0]] : [mapGain, mapOffset];
    gl.useProgram(this.program);
    gl.uniform1f(u.u_t, t);
    gl.uniformMatrix3fv(u.u_rotation, true, view.rotation);
    gl.uniform3fv(u.u_translation, view.translation);
    gl.uniform4f(u.u_intrinsics, view.fx, view.fy, view.cx, view.cy);
    gl.uniform2f(u.u_size, view.width, view.height);
    gl.uniform3fv(u.u_eye, view.eye);
    gl.uniform3fv(u.u_gain, gain);
    gl.uniform3fv(u.u_offset, offset);
    const images = imagesAt(this.settings, t);
    images.forEach(({ side, seam }, k) => {
      gl.bindFramebuffer(gl.FRAMEBUFFER, this.images[k].framebuffer);
      gl.clearColor(...background.map((b, c) => gain[c] * b + offset[c]), 1);
      gl.clear(gl.COLOR_BUFFER_BIT);
      gl.useProgram(this.program);
      gl.uniform1i(u.u_side, side);
      gl.uniform1f(u.u_side_seam, seam);
      if (this.instances > 0) this.drawSplats(view);
    });
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.disable(gl.BLEND);
    gl.useProgram(this.mixProgram);
    const m = this.mixUniforms;
    gl.uniform1i(m.u_before, this.images[0].unit);
    gl.uniform1i(m.u_after, this.images[images.length - 1].unit);
    gl.uniform1f(m.u_weight, images[0].weight);
    gl.uniform3fv(m.u_gain, this.halfFloat ? mapGain : [1, 1, 1]);
    gl.uniform3fv(m.u_offset, this.halfFloat ? mapOffset : [0, 0, 0]);
    gl.bindVertexArray(this.splatVao);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    gl.bindVertexArray(null);
  }

  drawSplats(view) {
    const gl = this.gl;
    // Pass 1: one record per primitive, in draw order.
    gl.bindVertexArray(this.prepareVao);
    gl.enable(gl.RASTERIZER_DISCARD);
    gl.bindTransformFeedback(gl.TRANSFORM_FEEDBACK, this.feedback);
    gl.bindBufferBase(gl.TRANSFORM_FEEDBACK_BUFFER, 0, this.recordBuffer);
    gl.beginTransformFeedback(gl.POINTS);
    gl.drawArrays(gl.POINTS, 0, this.instances);
    gl.endTransformFeedback();
    gl.bindBufferBase(gl.TRANSFORM_FEEDBACK_BUFFER, 0, null);
    gl.bindTransformFeedback(gl.TRANSFORM_FEEDBACK, null);
    gl.disable(gl.RASTERIZER_DISCARD);
    // The records into their texture, on the GPU.
    const rows = Math.ceil((4 * this.instances) / this.manifest.texture_width);
    gl.bindBuffer(gl.PIXEL_UNPACK_BUFFER, this.recordBuffer);
    gl.activeTexture(gl.TEXTURE0 + this.recordUnit);
    gl.bindTexture(gl.TEXTURE_2D, this.recordTexture);
    gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, this.manifest.texture_width, rows, gl.RGBA,
                     gl.FLOAT, 0);
    gl.bindBuffer(gl.PIXEL_UNPACK_BUFFER, null);
    // Pass 2: the quads, back to front.
    gl.useProgram(this.splatProgram);
    gl.uniform2f(this.splatUniforms.u_size, view.width, view.height);
    gl.enable(gl.BLEND);
    gl.blendFunc(gl.ONE, gl.ONE_MINUS_SRC_ALPHA);
    gl.disable(gl.DEPTH_TEST);
    gl.bindVertexArray(this.splatVao);
    gl.drawArrays(gl.TRIANGLES, 0, 6 * this.instances);
    gl.bindVertexArray(null);
  }
}
