// The viewer's time model (time_model.js) against the C++ one, on the cases that the C++ test
// TimeModelCases (tests/view/test_time_model_cases.cpp) writes into $RETIMEGS_TIME_MODEL_CASES:
// each model read from its model.json / model.bin as the viewer reads it (model_data.js), then
// σ_τ(t), the trajectory coefficients and x(t) of every case, σ of every row, and halfToFloat of
// every half float; for a merged model also σ_τ(t) drawn with each side of the nearest seam and
// the seam handover (which seam, its weight, which sides are drawn). ctest runs it as
// time_model_js after time_model_cases:
//
//   RETIMEGS_TIME_MODEL_CASES=DIR node --test web/test/time_model.test.mjs
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { test } from 'node:test';

import { readTextures, timeRows } from '../model_data.js';
import {
  SIDE_AFTER, SIDE_BEFORE, SIDE_NONE, halfToFloat, imagesAt, rowPosition, rowTemporalOpacity,
  seamHandover, timeSettings,
} from '../time_model.js';

const dir = process.env.RETIMEGS_TIME_MODEL_CASES;
if (!dir) throw new Error('RETIMEGS_TIME_MODEL_CASES is not set (the folder test_view writes)');
const cases = JSON.parse(readFileSync(join(dir, 'cases.json'), 'utf8'));

// Both sides compute in double from the same float32 parameters, with the same operations: they
// differ in the last bits only (exp's rounding, fused multiply-adds in the C++ build), 4e-16
// relative on these cases. A wrong formula, setting or packed field moves a value by far more
// than 1e-9; so does rounding a parameter to float32 (6e-8 relative) in between.
const kRelative = 1e-9;
// σ is held in float32 by the viewer and the C++ test alike: one float32 step apart at most.
const kFloatStep = 2 ** -23;

const readManifest = (name) => JSON.parse(readFileSync(join(dir, name, 'model.json'), 'utf8'));

function readModel(name) {
  const manifest = readManifest(name);
  const bin = readFileSync(join(dir, name, 'model.bin'));
  const buffer = bin.buffer.slice(bin.byteOffset, bin.byteOffset + bin.byteLength);
  return timeRows(manifest, readTextures(manifest, buffer));
}

// "what: got G, expected E" for values beyond `relative` of the expected one (and `absolute`).
function mismatch(what, got, expected, relative, absolute = 0) {
  return Math.abs(got - expected) <= relative * Math.abs(expected) + absolute
    ? null : `${what}: got ${got}, expected ${expected}`;
}

for (const model of cases.models) {
  test(`${model.name}: σ_τ(t), x(t) and σ of every case`, () => {
    const rows = readModel(model.name);
    assert.ok(model.cases.length > 0, 'no cases');
    const c = new Float64Array(3), x = new Float64Array(3);
    const failures = [];
    for (const k of model.cases) {
      const what = `row ${k.row} at t = ${k.t}`;
      failures.push(mismatch(`${what}, σ_τ`, rowTemporalOpacity(rows, k.row, k.t), k.temporal,
                             kRelative));
      rowPosition(rows, k.row, k.t, c, x);
      for (let a = 0; a < 3; ++a) {
        failures.push(mismatch(`${what}, coefficient ${a}`, c[a], k.coefficients[a], kRelative,
                               kRelative));
        failures.push(mismatch(`${what}, x[${a}]`, x[a], k.x[a], kRelative, kRelative));
      }
      failures.push(mismatch(`${what}, σ`, rows.opacity[k.row], k.opacity, kFloatStep));
      if (k.side_seam === undefined) continue;
      for (const [side, name, expected] of [[SIDE_BEFORE, 'before', k.temporal_before],
                                            [SIDE_AFTER, 'after', k.temporal_after]])
        failures.push(mismatch(`${what}, σ_τ ${name} the seam at ${k.side_seam}`,
                               rowTemporalOpacity(rows, k.row, k.t, side, k.side_seam), expected,
                               kRelative));
    }
    const found = failures.filter((f) => f !== null);
    assert.deepEqual(found.slice(0, 20), [], `${found.length} of the values differ`);
  });
}

const merged = cases.models.filter((model) => model.handovers.length > 0);

test('a merged model has side and handover cases', () => {
  assert.ok(merged.length > 0, 'no merged model among the cases');
  for (const model of merged) {
    // Cases where one side leaves a row out that the other draws: the side rule is exercised.
    assert.ok(model.cases.some((k) => (k.temporal_before === 0) !== (k.temporal_after === 0)),
              `${model.name}: no case that a side leaves out`);
    const drawn = new Set(model.handovers.map((h) => `${h.draws_before} ${h.draws_after}`));
    assert.deepEqual([...drawn].sort(), ['false true', 'true false', 'true true'],
                     `${model.name}: handovers that draw before only, after only and both`);
  }
});

for (const model of merged) {
  test(`${model.name}: the seam handover at every time`, () => {
    const settings = timeSettings(readManifest(model.name));
    const failures = [];
    for (const h of model.handovers) {
      const got = seamHandover(settings, h.t);
      const what = `t = ${h.t}`;
      if (got.seam !== h.seam) failures.push(`${what}: seam ${got.seam}, expected ${h.seam}`);
      failures.push(mismatch(`${what}, before`, got.before, h.before, kRelative));
      if (got.drawsBefore !== h.draws_before || got.drawsAfter !== h.draws_after)
        failures.push(`${what}: draws before ${got.drawsBefore}, after ${got.drawsAfter}; ` +
                      `expected ${h.draws_before}, ${h.draws_after}`);
      // The images the renderer draws: the sides drawn, their weights summing to one.
      const images = imagesAt(settings, h.t);
      const sides = images.map((image) => image.side);
      const expected = [...(h.draws_before ? [SIDE_BEFORE] : []),
                        ...(h.draws_after ? [SIDE_AFTER] : [])];
      if (sides.join() !== expected.join()) failures.push(`${what}: images of sides ${sides}`);
      failures.push(mismatch(`${what}, the first image's weight`, images[0].weight,
                             images.length === 2 ? h.before : 1, kRelative));
      if (images.some((image) => image.seam !== h.seam))
        failures.push(`${what}: an image of another seam`);
      const sum = images.reduce((total, image) => total + image.weight, 0);
      failures.push(mismatch(`${what}, the weights' sum`, sum, 1, 1e-15));
    }
    const found = failures.filter((f) => f !== null);
    assert.deepEqual(found.slice(0, 20), [], `${found.length} of the handovers differ`);
  });

  test(`${model.name}: a manifest without handover_tail is refused`, () => {
    const { handover_tail: _, ...old } = readManifest(model.name);
    assert.throws(() => timeSettings(old), /handover_tail/);
  });
}

test('a model without seams draws one image of every edge as it is', () => {
  for (const model of cases.models.filter((m) => m.handovers.length === 0)) {
    const settings = timeSettings(readManifest(model.name));
    assert.equal(seamHandover(settings, settings.first), null, model.name);
    assert.deepEqual(imagesAt(settings, settings.first),
                     [{ side: SIDE_NONE, seam: 0, weight: 1 }], model.name);
  }
});

test('halfToFloat: every half float as the C++ float_from_half reads it', () => {
  const bin = readFileSync(join(dir, cases.halves));
  const expected = new Float32Array(bin.buffer.slice(bin.byteOffset,
                                                     bin.byteOffset + bin.byteLength));
  assert.equal(expected.length, 65536);
  const wrong = [];
  for (let h = 0; h < 65536; ++h)
    if (!Object.is(halfToFloat(h), expected[h]))
      wrong.push(`0x${h.toString(16)}: got ${halfToFloat(h)}, expected ${expected[h]}`);
  assert.deepEqual(wrong.slice(0, 20), [], `${wrong.length} halves differ`);
});
