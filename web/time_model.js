// The time model of model::slice (include/retimegs/model/temporal_opacity.hpp, trajectory.hpp)
// in JavaScript, for the sort worker; the vertex shader in renderer.js is its GLSL twin. Both
// read the packed arrays of model.json / model.bin (docs/formats.md, "The viewer's data").
// web/test/time_model.test.mjs checks it against the C++ values (ctest: time_model_js).

// The settings of a manifest that the time model needs.
export function timeSettings(manifest) {
  return {
    stgs: manifest.representation === 'stgs',
    linear: manifest.trajectory === 'linear',
    first: manifest.time.first,
    last: manifest.time.last,
    step: manifest.time.step,
    gamma: manifest.gamma_frames,
    epsilon: manifest.epsilon,
    seams: manifest.seams ?? [],  // a merged model's seams, times (frames)
    seamScale: manifest.seam_scale_frames ?? manifest.gamma_frames,
  };
}

// The sigmoid scale of a closed edge at time `edge` (RetimeWindow::edge_scale): the seam's at a
// seam (within ε), γ elsewhere.
export function edgeScale(s, edge) {
  for (const seam of s.seams)
    if (Math.abs(edge - seam) <= s.epsilon) return s.seamScale;
  return s.gamma;
}

const sigmoid = (x) => 1 / (1 + Math.exp(-x));

// σ_τ(t): RetimeWindow (a sigmoid edge of width γ, or a seam's own scale, on each side of
// [μ_τ - τ_l, μ_τ + τ_r], an edge within ε of the clip's first / last training time open), or the
// STGS Gaussian.
export function temporalOpacity(s, muTau, tauL, tauR, temporalLogScale, t) {
  if (s.stgs) {
    const d = (t - muTau) * Math.exp(-temporalLogScale);
    return Math.exp(-d * d);
  }
  const openLeft = Math.fround(muTau - tauL) <= Math.fround(s.first + s.epsilon);
  const openRight = Math.fround(muTau + tauR) >= Math.fround(s.last - s.epsilon);
  const a = muTau - tauL, b = muTau + tauR;
  const left = openLeft ? 1 : sigmoid((t - a) / edgeScale(s, a));
  const right = openRight ? 1 : sigmoid((b - t) / edgeScale(s, b));
  return left * right;
}

// The coefficients c of x(t) = μ + c0 v1 + c1 v2 + c2 v3 (trajectory_at): Catmull-Rom through
// the control points p1 = μ - ½Δt v2, p2 = μ + ½Δt v2, p0 = p1 - Δt v1, p3 = p2 + Δt v3 on the
// primitive's interval [μ_τ - Δt/2, μ_τ + Δt/2], continued linearly outside it.
export function trajectoryCoefficients(s, muTau, t, out) {
  if (s.stgs) {
    const d = t - muTau;
    out[0] = d, out[1] = d * d, out[2] = d * d * d;
    return out;
  }
  if (s.linear) {
    out[0] = 0, out[1] = t - muTau, out[2] = 0;
    return out;
  }
  const step = s.step;
  const u = (t - (muTau - step / 2)) / step;
  let w0, w1, w2, w3;
  if (u < 0) {
    w0 = -u / 2, w1 = 1, w2 = u / 2, w3 = 0;
  } else if (u > 1) {
    w0 = 0, w1 = -(u - 1) / 2, w2 = 1, w3 = (u - 1) / 2;
  } else {
    const u2 = u * u, u3 = u2 * u;
    w0 = (-u + 2 * u2 - u3) / 2;
    w1 = (2 - 5 * u2 + 3 * u3) / 2;
    w2 = (u + 4 * u2 - 3 * u3) / 2;
    w3 = (-u2 + u3) / 2;
  }
  out[0] = -step * w0;
  out[1] = (step / 2) * (-w0 - w1 + w2 + w3);
  out[2] = step * w3;
  return out;
}

// σ_τ(t) of row i of `rows` (timeRows in model_data.js, which says where each value lies).
export function rowTemporalOpacity(rows, i, t) {
  const k = 4 * i + 3;
  return temporalOpacity(rows.settings, rows.mu[k], rows.v1[k], rows.v2[k], rows.v3[k], t);
}

// x(t) of row i into out; c receives its trajectory coefficients.
export function rowPosition(rows, i, t, c, out) {
  const { mu, v1, v2, v3 } = rows;
  const k = 4 * i;
  trajectoryCoefficients(rows.settings, mu[k + 3], t, c);
  for (let a = 0; a < 3; ++a)
    out[a] = mu[k + a] + c[0] * v1[k + a] + c[1] * v2[k + a] + c[2] * v3[k + a];
  return out;
}

// IEEE binary16 to number.
export function halfToFloat(h) {
  const sign = h & 0x8000 ? -1 : 1;
  const exponent = (h >> 10) & 0x1f, mantissa = h & 0x3ff;
  if (exponent === 0) return sign * mantissa * 2 ** -24;
  if (exponent === 31) return mantissa ? NaN : sign * Infinity;
  return sign * (1 + mantissa / 1024) * 2 ** (exponent - 15);
}
