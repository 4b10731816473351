// The time model of model::slice (include/retimegs/model/temporal_opacity.hpp, trajectory.hpp)
// in JavaScript, for the sort worker; the vertex shader in renderer.js is its GLSL twin. Both
// read the packed arrays of model.json / model.bin (docs/formats.md, "The viewer's data").
// web/test/time_model.test.mjs checks it against the C++ values (ctest: time_model_js).

// Which side of a seam an image draws (model::SeamSide, the same values): SIDE_BEFORE the window
// that ends at the seam alone, SIDE_AFTER the one that starts there, SIDE_NONE every edge as it is.
export const SIDE_BEFORE = -1, SIDE_NONE = 0, SIDE_AFTER = 1;

// The settings of a manifest that the time model needs. A merged model's manifest carries the
// handover's tail (model::kHandoverTail), written by the same retimegs that serves this page.
export function timeSettings(manifest) {
  const seams = manifest.seams ?? [];
  if (seams.length && typeof manifest.handover_tail !== 'number')
    throw new Error('model.json: a merged model without handover_tail (packed by an older ' +
                    'retimegs: serve or export the model again)');
  return {
    stgs: manifest.representation === 'stgs',
    linear: manifest.trajectory === 'linear',
    first: manifest.time.first,
    last: manifest.time.last,
    step: manifest.time.step,
    gamma: manifest.gamma_frames,
    epsilon: manifest.epsilon,
    seams,  // a merged model's seams, times (frames)
    seamScale: manifest.seam_scale_frames ?? manifest.gamma_frames,
    handoverTail: manifest.handover_tail,  // with seams only
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
// STGS Gaussian. Drawn for one `side` of the seam at `sideSeam` (frames), an edge within ε of that
// seam is open on its own side, and the primitive is left out (0) on the other: with SIDE_BEFORE
// one that starts at the seam, with SIDE_AFTER one that ends there (RetimeWindow::other_side).
export function temporalOpacity(s, muTau, tauL, tauR, temporalLogScale, t, side = SIDE_NONE,
                                sideSeam = 0) {
  if (s.stgs) {
    const d = (t - muTau) * Math.exp(-temporalLogScale);
    return Math.exp(-d * d);
  }
  const openLeft = Math.fround(muTau - tauL) <= Math.fround(s.first + s.epsilon);
  const openRight = Math.fround(muTau + tauR) >= Math.fround(s.last - s.epsilon);
  const a = muTau - tauL, b = muTau + tauR;
  const atLeft = side !== SIDE_NONE && Math.abs(a - sideSeam) <= s.epsilon;
  const atRight = side !== SIDE_NONE && Math.abs(b - sideSeam) <= s.epsilon;
  if ((side === SIDE_BEFORE && !openLeft && atLeft) ||
      (side === SIDE_AFTER && !openRight && atRight)) return 0;
  const left = openLeft || atLeft ? 1 : sigmoid((t - a) / edgeScale(s, a));
  const right = openRight || atRight ? 1 : sigmoid((b - t) / edgeScale(s, b));
  return left * right;
}

// The seam handover at time t (model::seam_handover), or null for a model without seams: the
// seam nearest t (frames; the first of two as near), the weight `before` = ψ((seam - t) / F) of
// the image of SIDE_BEFORE (SIDE_AFTER's is 1 - before), and which sides are drawn: a side whose
// weight is within the tail of 0 is not.
export function seamHandover(s, t) {
  if (!s.seams.length) return null;
  let seam = s.seams[0];
  for (const at of s.seams)
    if (Math.abs(at - t) < Math.abs(seam - t)) seam = at;
  const before = sigmoid((seam - t) / s.seamScale);
  return { seam, before, drawsBefore: before > s.handoverTail,
           drawsAfter: before < 1 - s.handoverTail };
}

// The images that make the frame at t: [{side, seam, weight}], the weights summing to one. One
// image (SIDE_NONE) for a model without seams, one side alone far from a seam, both near it.
export function imagesAt(s, t) {
  const h = seamHandover(s, t);
  if (!h) return [{ side: SIDE_NONE, seam: 0, weight: 1 }];
  if (!h.drawsAfter) return [{ side: SIDE_BEFORE, seam: h.seam, weight: 1 }];
  if (!h.drawsBefore) return [{ side: SIDE_AFTER, seam: h.seam, weight: 1 }];
  return [{ side: SIDE_BEFORE, seam: h.seam, weight: h.before },
          { side: SIDE_AFTER, seam: h.seam, weight: 1 - h.before }];
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

// σ_τ(t) of row i of `rows` (timeRows in model_data.js, which says where each value lies), drawn
// for `side` of the seam at `sideSeam` as in temporalOpacity.
export function rowTemporalOpacity(rows, i, t, side = SIDE_NONE, sideSeam = 0) {
  const k = 4 * i + 3;
  return temporalOpacity(rows.settings, rows.mu[k], rows.v1[k], rows.v2[k], rows.v3[k], t, side,
                         sideSeam);
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
