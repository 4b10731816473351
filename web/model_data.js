// model.json and model.bin (docs/formats.md, "The viewer's data") as the viewer reads them: typed
// views of the packed textures, and the rows of the time model that the sort worker evaluates.
import { halfToFloat, timeSettings } from './time_model.js';

// The textures of model.bin by name: {data (Uint16Array of half floats or Float32Array, 4 values
// per texel), half, height, texelsPerPrimitive}. Throws on a manifest of another format or a
// texture beyond the end of the buffer.
export function readTextures(manifest, buffer) {
  if (manifest.format !== 'retimegs-web' || manifest.version !== 1)
    throw new Error(`model.json: not a retimegs viewer manifest of version 1`);
  const textures = {};
  for (const t of manifest.textures) {
    if (t.offset + t.bytes > buffer.byteLength)
      throw new Error(`model.bin: ${buffer.byteLength} bytes, texture ${t.name} ends at ` +
                      `${t.offset + t.bytes}`);
    const data = t.type === 'rgba16f' ? new Uint16Array(buffer, t.offset, t.bytes / 2)
                                      : new Float32Array(buffer, t.offset, t.bytes / 4);
    textures[t.name] = { data, half: t.type === 'rgba16f', height: t.height,
                         texelsPerPrimitive: t.texels_per_primitive };
  }
  return textures;
}

// What the time model reads (time_model.js, rowTemporalOpacity and rowPosition), copied out of the
// textures: 4 floats per row in mu = (μ, μ_τ), v1 = (v1, τ_l), v2 = (v2, τ_r), v3 = (v3, the STGS
// temporal log-scale); opacity = σ of the half-float logit in shape.w; the manifest's settings.
export function timeRows(manifest, textures) {
  const n = manifest.count;
  const opacity = new Float32Array(n);
  const shape = textures.shape.data;
  for (let i = 0; i < n; ++i) opacity[i] = 1 / (1 + Math.exp(-halfToFloat(shape[4 * i + 3])));
  const slice = (name) => textures[name].data.slice(0, 4 * n);
  return { count: n, mu: slice('mu'), v1: slice('v1'), v2: slice('v2'), v3: slice('v3'), opacity,
           minOpacity: manifest.min_opacity, settings: timeSettings(manifest) };
}
