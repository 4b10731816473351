// Depth sort at the current time, off the main thread. Given the packed positions and windows
// (posted once) and a request {id, t, zRow, near}, it evaluates every primitive's position at t,
// keeps those the vertex shader draws (σ·σ_τ(t) >= 1/255, camera z >= near) and returns their
// indices ordered back to front by camera z, the order the renderer composites in reverse. Near a
// merged model's seam the renderer draws two images, one per side (imagesAt), in this one order:
// a primitive is kept when either side draws it.
import { imagesAt, rowPosition, rowTemporalOpacity } from './time_model.js';

let model = null;  // timeRows (model_data.js)
let depthBits = new Uint32Array(0), keysA = new Uint32Array(0), keysB = new Uint32Array(0);
let idsA = new Uint32Array(0), idsB = new Uint32Array(0);

function ensure(n) {
  if (depthBits.length >= n) return;
  depthBits = new Uint32Array(n);
  keysA = new Uint32Array(n), keysB = new Uint32Array(n);
  idsA = new Uint32Array(n), idsB = new Uint32Array(n);
}

// LSD radix sort of (key, id) pairs on 32-bit keys, 11-bit digits: stable, O(n).
function radixSort(n) {
  let keys = keysA, ids = idsA, keysOut = keysB, idsOut = idsB;
  const counts = new Uint32Array(2048);
  for (let shift = 0; shift < 32; shift += 11) {
    counts.fill(0);
    for (let i = 0; i < n; ++i) counts[(keys[i] >>> shift) & 2047]++;
    let sum = 0;
    for (let d = 0; d < 2048; ++d) {
      const c = counts[d];
      counts[d] = sum;
      sum += c;
    }
    for (let i = 0; i < n; ++i) {
      const at = counts[(keys[i] >>> shift) & 2047]++;
      keysOut[at] = keys[i];
      idsOut[at] = ids[i];
    }
    [keys, keysOut] = [keysOut, keys];
    [ids, idsOut] = [idsOut, ids];
  }
  return ids;  // 3 passes: the result is in the B arrays
}

function sortAt(request) {
  const { count, opacity, minOpacity } = model;
  const [r0, r1, r2] = request.zRow;
  const tz = request.tz, near = request.near, t = request.t;
  const c = new Float64Array(3), x = new Float64Array(3);
  const f32 = new Float32Array(1), bits = new Uint32Array(f32.buffer);
  const images = imagesAt(model.settings, t);
  let visible = 0;
  for (let i = 0; i < count; ++i) {
    let drawn = false;
    for (const { side, seam } of images)
      drawn ||= !(opacity[i] * rowTemporalOpacity(model, i, t, side, seam) < minOpacity);
    if (!drawn) continue;
    rowPosition(model, i, t, c, x);
    const depth = r0 * x[0] + r1 * x[1] + r2 * x[2] + tz;
    if (!(depth >= near)) continue;
    // Positive floats order as their bit patterns; the complement sorts far to near.
    f32[0] = depth;
    keysA[visible] = ~bits[0] >>> 0;
    idsA[visible] = i;
    ++visible;
  }
  const ids = radixSort(visible);
  return ids.slice(0, visible);
}

self.onmessage = (event) => {
  const message = event.data;
  if (message.type === 'model') {
    model = message.model;
    ensure(model.count);
    return;
  }
  const start = performance.now();
  const order = sortAt(message);
  const ms = performance.now() - start;
  self.postMessage({ id: message.id, order, ms }, [order.buffer]);
};
