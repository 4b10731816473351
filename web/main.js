// The viewer page: loads model.json and model.bin beside it, draws the model at the current time
// (renderer.js), keeps the depth order current through the sort worker, and runs the timeline and
// camera controls. URL parameters: camera=NAME (the canvas takes that scene camera's size,
// intrinsics and colour map, as `retimegs render --camera NAME` draws it), t=T (scene frame
// units), speed=S, paused=1, loop=0. window.retimegs.frameReady turns true once a frame has been
// drawn, with its own depth order, for the requested state.
import { Navigator, sceneView } from './camera.js';
import { readTextures, timeRows } from './model_data.js';
import { Renderer } from './renderer.js';

const $ = (id) => document.getElementById(id);
const canvas = $('canvas'), hud = $('hud');
// Timings in ms since the navigation started: model data fetched, textures uploaded, first frame
// shown (loadMs); sortMs is the worker's last sort.
const api = { frameReady: false, fetchedMs: null, uploadedMs: null, loadMs: null, sortMs: null,
              visible: 0, error: null };
window.retimegs = api;

function showMessage(text) {
  api.error = text;
  $('message').textContent = text;
  $('message').classList.add('shown');
  hud.textContent = '';
}

async function load() {
  const gl = canvas.getContext('webgl2', { antialias: false, alpha: false, depth: false,
                                           preserveDrawingBuffer: true });
  if (!gl) {
    showMessage('This viewer needs WebGL2, which this browser does not provide here. Enable ' +
                'hardware acceleration, or open the page in a current Chrome, Edge, Firefox ' +
                'or Safari.');
    return;
  }
  hud.textContent = 'loading model…';
  const [manifestResponse, dataResponse] = await Promise.all([fetch('model.json'),
                                                              fetch('model.bin')]);
  if (!manifestResponse.ok || !dataResponse.ok)
    throw new Error(`cannot load the model (model.json: HTTP ${manifestResponse.status}, ` +
                    `model.bin: HTTP ${dataResponse.status})`);
  const manifest = await manifestResponse.json();
  const buffer = await dataResponse.arrayBuffer();
  const fetchedMs = performance.now();
  const textures = readTextures(manifest, buffer);
  const renderer = new Renderer(gl, manifest, textures);
  api.fetchedMs = fetchedMs;
  api.uploadedMs = performance.now();
  start(manifest, renderer, textures);
}

function start(manifest, renderer, textures) {
  const n = manifest.count;
  const first = manifest.time.first, last = manifest.time.last;
  const params = new URLSearchParams(location.search);
  const fps = manifest.fps || 30;

  // The sort worker gets its own copies of what positions and visibility need.
  const worker = new Worker(new URL('./sort_worker.js', import.meta.url), { type: 'module' });
  worker.postMessage({ type: 'model', model: timeRows(manifest, textures) });

  const state = {
    t: clampTime(Number(params.get('t') ?? first)),
    playing: params.get('paused') !== '1',
    speed: Number(params.get('speed') ?? 1),
    loop: params.get('loop') !== '0',
    camera: null,  // a scene camera's index, or null for free navigation
    mode: 'orbit',
  };
  if (!(state.speed > 0 && Number.isFinite(state.speed))) state.speed = 1;
  const navigator_ = new Navigator(manifest.up, manifest.center, manifest.radius);
  if (manifest.cameras.length) navigator_.setFromView(sceneView(manifest.cameras[0]),
                                                       manifest.center);

  function clampTime(t) {
    return Number.isFinite(t) ? Math.min(last, Math.max(first, t)) : first;
  }

  // Controls.
  const slider = $('slider'), timeLabel = $('time'), playButton = $('play');
  slider.min = first, slider.max = last, slider.value = state.t;
  const ticks = $('ticks');
  const training = new Set(manifest.training_frames.map((f) => Math.round(f * 1e6)));
  const span = last - first || 1;
  for (let f = Math.ceil(first); f <= last && last - first <= 2000; ++f) {
    const tick = document.createElement('span');
    tick.style.left = `${((f - first) / span) * 100}%`;
    if (training.has(Math.round(f * 1e6))) tick.className = 'train';
    tick.title = `frame ${f}${tick.className ? ' (training)' : ''}`;
    ticks.appendChild(tick);
  }
  for (const f of manifest.training_frames) {
    if (Number.isInteger(f)) continue;
    const tick = document.createElement('span');
    tick.className = 'train';
    tick.style.left = `${((f - first) / span) * 100}%`;
    ticks.appendChild(tick);
  }
  const speedSelect = $('speed');
  if (![...speedSelect.options].some((o) => Number(o.value) === state.speed)) {
    const option = new Option(`${state.speed}×`, String(state.speed));
    speedSelect.add(option);
  }
  speedSelect.value = String(state.speed);
  speedSelect.onchange = () => { state.speed = Number(speedSelect.value); };
  $('loop').checked = state.loop;
  $('loop').onchange = () => { state.loop = $('loop').checked; };
  const setTime = (t) => { state.t = clampTime(t); changed(); };
  slider.oninput = () => setTime(Number(slider.value));
  const togglePlay = () => {
    if (!state.playing && state.t >= last && !state.loop) state.t = first;
    state.playing = !state.playing;
    changed();
  };
  playButton.onclick = togglePlay;
  const stepSize = () => Number($('step').value);
  const nextFrame = () => setTime(Math.floor(state.t + 1e-6) + 1);
  const prevFrame = () => setTime(Math.ceil(state.t - 1e-6) - 1);
  $('next-frame').onclick = () => { state.playing = false; nextFrame(); };
  $('prev-frame').onclick = () => { state.playing = false; prevFrame(); };
  $('step-forward').onclick = () => { state.playing = false; setTime(state.t + stepSize()); };
  $('step-back').onclick = () => { state.playing = false; setTime(state.t - stepSize()); };

  const cameraSelect = $('camera');
  manifest.cameras.forEach((c, k) => cameraSelect.add(new Option(`${c.name} (${c.split})`, k)));
  cameraSelect.onchange = () => {
    if (cameraSelect.value === '') leaveCamera();
    else state.camera = Number(cameraSelect.value);
    layout();
  };
  $('mode').onchange = () => { state.mode = $('mode').value; };
  const requested = params.get('camera');
  if (requested !== null) {
    const k = manifest.cameras.findIndex((c) => c.name === requested);
    if (k < 0) {
      const names = manifest.cameras.map((c) => c.name).join(', ') || 'none: served without --scene';
      showMessage(`camera=${requested}: no such camera in the scene (cameras: ${names})`);
      return;
    }
    state.camera = k;
    cameraSelect.value = String(k);
  }

  // Leaving a scene camera: free navigation continues from where it looks.
  function leaveCamera() {
    if (state.camera === null) return;
    navigator_.setFromView(sceneView(manifest.cameras[state.camera]), manifest.center);
    state.camera = null;
    cameraSelect.value = '';
    layout();
  }

  // Canvas size: a scene camera's own; free navigation fills the stage.
  function layout() {
    const stage = $('stage');
    if (state.camera !== null) {
      const c = manifest.cameras[state.camera];
      canvas.classList.remove('fill');
      canvas.width = c.width, canvas.height = c.height;
    } else {
      canvas.classList.add('fill');
      const dpr = window.devicePixelRatio || 1;
      canvas.width = Math.max(1, Math.round(stage.clientWidth * dpr));
      canvas.height = Math.max(1, Math.round(stage.clientHeight * dpr));
    }
    changed();
  }
  window.addEventListener('resize', layout);

  // Pointer: drag orbits (fly: looks), right or shift drag pans, wheel zooms.
  let drag = null;
  canvas.addEventListener('contextmenu', (e) => e.preventDefault());
  canvas.addEventListener('pointerdown', (e) => {
    drag = { x: e.clientX, y: e.clientY, pan: e.button === 2 || e.shiftKey };
    canvas.setPointerCapture(e.pointerId);
  });
  canvas.addEventListener('pointermove', (e) => {
    if (!drag) return;
    const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    drag.x = e.clientX, drag.y = e.clientY;
    if (dx === 0 && dy === 0) return;
    leaveCamera();
    if (drag.pan) navigator_.pan(dx, dy);
    else if (state.mode === 'fly') navigator_.look(dx, dy);
    else navigator_.orbit(dx, dy);
    changed();
  });
  canvas.addEventListener('pointerup', () => { drag = null; });
  canvas.addEventListener('wheel', (e) => {
    e.preventDefault();
    leaveCamera();
    if (state.mode === 'fly') navigator_.fly(-Math.sign(e.deltaY) * 0.05, 0, 0);
    else navigator_.zoom(Math.exp(e.deltaY * 0.001));
    changed();
  }, { passive: false });
  const held = new Set();
  window.addEventListener('keydown', (e) => {
    if (e.target instanceof HTMLSelectElement || e.target instanceof HTMLInputElement &&
        e.target.type !== 'range') return;
    if (e.key === ' ') { e.preventDefault(); togglePlay(); }
    else if (e.key === 'ArrowRight') { e.preventDefault(); state.playing = false; setTime(state.t + stepSize()); }
    else if (e.key === 'ArrowLeft') { e.preventDefault(); state.playing = false; setTime(state.t - stepSize()); }
    else if (e.key === '.') { state.playing = false; nextFrame(); }
    else if (e.key === ',') { state.playing = false; prevFrame(); }
    else if ('wasdqe'.includes(e.key.toLowerCase())) held.add(e.key.toLowerCase());
  });
  window.addEventListener('keyup', (e) => held.delete(e.key.toLowerCase()));

  // Frame loop. A state is the time and the view; the worker sorts the latest state whenever it
  // is idle, and a frame drawn with the order of the state it shows makes frameReady true.
  let dirty = true, busy = false, sortedKey = null, requestId = 0, pendingKey = null;
  let lastTime = performance.now(), frames = 0, fpsShown = 0, fpsSince = lastTime;
  let firstFrame = true;
  function changed() { dirty = true; api.frameReady = false; }
  function currentView() {
    return state.camera !== null ? sceneView(manifest.cameras[state.camera])
                                 : navigator_.view(canvas.width, canvas.height);
  }
  const keyOf = (view) => JSON.stringify([state.t, view.rotation, view.translation, view.width,
                                          view.height, view.fx, view.fy, view.cx, view.cy]);
  worker.onmessage = (e) => {
    busy = false;
    renderer.setOrder(e.data.order);
    api.sortMs = e.data.ms;
    api.visible = e.data.order.length;
    sortedKey = pendingKey;
    dirty = true;
  };
  worker.onerror = (e) => showMessage(`sort worker: ${e.message}`);

  function tick(now) {
    const elapsed = Math.min(0.25, (now - lastTime) / 1000);
    lastTime = now;
    if (state.playing) {
      let t = state.t + elapsed * fps * state.speed;
      if (t > last) {
        if (state.loop && last > first) t = first + ((t - first) % (last - first));
        else t = last, state.playing = false;
      }
      state.t = t;
      changed();
    }
    if (held.size) {
      leaveCamera();
      const s = elapsed;
      navigator_.fly((held.has('w') - held.has('s')) * s, (held.has('d') - held.has('a')) * s,
                     (held.has('e') - held.has('q')) * s);
      changed();
    }
    const view = currentView();
    const key = keyOf(view);
    if (!busy && key !== sortedKey) {
      busy = true;
      pendingKey = key;
      worker.postMessage({ type: 'sort', id: ++requestId, t: state.t,
                           zRow: view.rotation.slice(6, 9), tz: view.translation[2],
                           near: manifest.near });
    }
    if (dirty && sortedKey !== null) {
      renderer.draw(view, state.t, manifest.background);
      dirty = false;
      ++frames;
      if (key === sortedKey) {
        // Shown once the compositor has taken this frame: the next animation frame.
        requestAnimationFrame(() => {
          if (keyOf(currentView()) === key && !dirty) {
            api.frameReady = true;
            if (firstFrame) {
              // Reading a pixel waits for the GPU to finish the frame.
              firstFrame = false;
              renderer.gl.readPixels(0, 0, 1, 1, renderer.gl.RGBA, renderer.gl.UNSIGNED_BYTE,
                                     new Uint8Array(4));
              api.loadMs = performance.now();  // since the navigation started
            }
          }
        });
      }
    }
    if (now - fpsSince >= 1000) {
      fpsShown = (frames * 1000) / (now - fpsSince);
      frames = 0, fpsSince = now;
    }
    slider.value = state.t;
    playButton.textContent = state.playing ? 'II' : '▶';
    const atTraining = training.has(Math.round(state.t * 1e6));
    timeLabel.textContent = `t = ${state.t.toFixed(3)}${atTraining ? ' (training)' : ''}`;
    hud.textContent = `${fpsShown.toFixed(1)} fps · ${api.visible.toLocaleString('en')} / ` +
                      `${n.toLocaleString('en')} visible · sort ${api.sortMs?.toFixed(1) ?? '–'} ms`;
    requestAnimationFrame(tick);
  }

  api.setTime = (t) => { state.playing = false; setTime(t); };
  api.state = () => ({ t: state.t, playing: state.playing, speed: state.speed,
                       camera: state.camera === null ? null : manifest.cameras[state.camera].name,
                       width: canvas.width, height: canvas.height });
  layout();
  requestAnimationFrame(tick);
}

load().catch((error) => showMessage(`retimegs viewer: ${error.message}`));
