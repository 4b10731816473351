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
const slider = $('slider'), timeLabel = $('time'), playButton = $('play');
const cameraSelect = $('camera');
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

// The viewer on a loaded model: the sort worker, the state the URL asks for, the controls, then
// the frame loop. An unknown camera=NAME stops it with a message.
function start(manifest, renderer, textures) {
  const params = new URLSearchParams(location.search);
  const worker = startSortWorker(manifest, textures);
  const v = createViewer(manifest, renderer, worker, params);
  bindTimeline(v);
  if (!bindCameras(v, params.get('camera'))) return;
  window.addEventListener('resize', () => layout(v));
  bindPointer(v);
  bindKeys(v);
  runFrameLoop(v);
}

// The sort worker (sort_worker.js) with its own copy of the rows the time model reads.
function startSortWorker(manifest, textures) {
  const worker = new Worker(new URL('./sort_worker.js', import.meta.url), { type: 'module' });
  worker.postMessage({ type: 'model', model: timeRows(manifest, textures) });
  return worker;
}

// The viewer's record: the model, the playback and camera state (from the URL parameters t,
// paused, speed, loop; the view of the first scene camera) and the frame loop's bookkeeping.
function createViewer(manifest, renderer, worker, params) {
  const v = {
    manifest, renderer, worker,
    first: manifest.time.first, last: manifest.time.last,
    fps: manifest.fps || 30,
    // Training times in microframes, to mark them on the timeline and in the time label.
    training: new Set(manifest.training_frames.map((f) => Math.round(f * 1e6))),
    state: null,
    navigator: new Navigator(manifest.up, manifest.center, manifest.radius),
    held: new Set(),  // fly keys held down
    // A state is the time and the view; the worker sorts the latest state whenever it is idle,
    // and a frame drawn with the order of the state it shows makes frameReady true.
    dirty: true, busy: false, sortedKey: null, requestId: 0, pendingKey: null,
    lastTime: 0, frames: 0, fpsShown: 0, fpsSince: 0, firstFrame: true,
  };
  v.state = {
    t: clampTime(v, Number(params.get('t') ?? v.first)),
    playing: params.get('paused') !== '1',
    speed: Number(params.get('speed') ?? 1),
    loop: params.get('loop') !== '0',
    camera: null,  // a scene camera's index, or null for free navigation
    mode: 'orbit',
  };
  if (!(v.state.speed > 0 && Number.isFinite(v.state.speed))) v.state.speed = 1;
  if (manifest.cameras.length) v.navigator.setFromView(sceneView(manifest.cameras[0]),
                                                       manifest.center);
  return v;
}

function clampTime(v, t) {
  return Number.isFinite(t) ? Math.min(v.last, Math.max(v.first, t)) : v.first;
}

// Something shown changed: the next animation frame draws, and frameReady waits for it.
function changed(v) {
  v.dirty = true;
  api.frameReady = false;
}

function setTime(v, t) {
  v.state.t = clampTime(v, t);
  changed(v);
}

function togglePlay(v) {
  const state = v.state;
  if (!state.playing && state.t >= v.last && !state.loop) state.t = v.first;
  state.playing = !state.playing;
  changed(v);
}

const stepSize = () => Number($('step').value);

// Pauses and moves the time: by `dt`, or to the next / previous whole frame (direction ±1).
function stepTime(v, dt) {
  v.state.playing = false;
  setTime(v, v.state.t + dt);
}
function stepFrame(v, direction) {
  v.state.playing = false;
  const t = v.state.t;
  setTime(v, direction > 0 ? Math.floor(t + 1e-6) + 1 : Math.ceil(t - 1e-6) - 1);
}

// The timeline's controls: slider, frame ticks, speed, loop, play and the step buttons.
function bindTimeline(v) {
  const { state, first, last } = v;
  slider.min = first, slider.max = last, slider.value = state.t;
  addTicks(v);
  const speedSelect = $('speed');
  if (![...speedSelect.options].some((o) => Number(o.value) === state.speed)) {
    const option = new Option(`${state.speed}×`, String(state.speed));
    speedSelect.add(option);
  }
  speedSelect.value = String(state.speed);
  speedSelect.onchange = () => { state.speed = Number(speedSelect.value); };
  $('loop').checked = state.loop;
  $('loop').onchange = () => { state.loop = $('loop').checked; };
  slider.oninput = () => setTime(v, Number(slider.value));
  playButton.onclick = () => togglePlay(v);
  $('next-frame').onclick = () => stepFrame(v, 1);
  $('prev-frame').onclick = () => stepFrame(v, -1);
  $('step-forward').onclick = () => stepTime(v, stepSize());
  $('step-back').onclick = () => stepTime(v, -stepSize());
}

// A tick under the slider at every whole frame (training frames marked) and at every training
// time between frames.
function addTicks(v) {
  const { first, last, training } = v;
  const ticks = $('ticks');
  const span = last - first || 1;
  for (let f = Math.ceil(first); f <= last && last - first <= 2000; ++f) {
    const tick = document.createElement('span');
    tick.style.left = `${((f - first) / span) * 100}%`;
    if (training.has(Math.round(f * 1e6))) tick.className = 'train';
    tick.title = `frame ${f}${tick.className ? ' (training)' : ''}`;
    ticks.appendChild(tick);
  }
  for (const f of v.manifest.training_frames) {
    if (Number.isInteger(f)) continue;
    const tick = document.createElement('span');
    tick.className = 'train';
    tick.style.left = `${((f - first) / span) * 100}%`;
    ticks.appendChild(tick);
  }
}

// The camera menu, the navigation mode, and the camera=NAME parameter (`requested`): false, with
// a message shown, when the scene has no such camera.
function bindCameras(v, requested) {
  const { manifest, state } = v;
  manifest.cameras.forEach((c, k) => cameraSelect.add(new Option(`${c.name} (${c.split})`, k)));
  cameraSelect.onchange = () => {
    if (cameraSelect.value === '') leaveCamera(v);
    else state.camera = Number(cameraSelect.value);
    layout(v);
  };
  $('mode').onchange = () => { state.mode = $('mode').value; };
  if (requested === null) return true;
  const k = manifest.cameras.findIndex((c) => c.name === requested);
  if (k < 0) {
    const names = manifest.cameras.map((c) => c.name).join(', ') || 'none: served without --scene';
    showMessage(`camera=${requested}: no such camera in the scene (cameras: ${names})`);
    return false;
  }
  state.camera = k;
  cameraSelect.value = String(k);
  return true;
}

// Leaving a scene camera: free navigation continues from where it looks.
function leaveCamera(v) {
  const state = v.state;
  if (state.camera === null) return;
  v.navigator.setFromView(sceneView(v.manifest.cameras[state.camera]), v.manifest.center);
  state.camera = null;
  cameraSelect.value = '';
  layout(v);
}

// Canvas size: a scene camera's own; free navigation fills the stage.
function layout(v) {
  const stage = $('stage');
  if (v.state.camera !== null) {
    const c = v.manifest.cameras[v.state.camera];
    canvas.classList.remove('fill');
    canvas.width = c.width, canvas.height = c.height;
  } else {
    canvas.classList.add('fill');
    const dpr = window.devicePixelRatio || 1;
    canvas.width = Math.max(1, Math.round(stage.clientWidth * dpr));
    canvas.height = Math.max(1, Math.round(stage.clientHeight * dpr));
  }
  changed(v);
}

// Pointer: drag orbits (fly: looks), right or shift drag pans, wheel zooms.
function bindPointer(v) {
  const navigator_ = v.navigator;
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
    leaveCamera(v);
    if (drag.pan) navigator_.pan(dx, dy);
    else if (v.state.mode === 'fly') navigator_.look(dx, dy);
    else navigator_.orbit(dx, dy);
    changed(v);
  });
  canvas.addEventListener('pointerup', () => { drag = null; });
  canvas.addEventListener('wheel', (e) => {
    e.preventDefault();
    leaveCamera(v);
    if (v.state.mode === 'fly') navigator_.fly(-Math.sign(e.deltaY) * 0.05, 0, 0);
    else navigator_.zoom(Math.exp(e.deltaY * 0.001));
    changed(v);
  }, { passive: false });
}

// Keys: space plays or pauses, arrows step by the step size, '.' and ',' by a frame; WASDQE fly
// while held (the frame loop moves).
function bindKeys(v) {
  window.addEventListener('keydown', (e) => {
    if (e.target instanceof HTMLSelectElement || e.target instanceof HTMLInputElement &&
        e.target.type !== 'range') return;
    if (e.key === ' ') { e.preventDefault(); togglePlay(v); }
    else if (e.key === 'ArrowRight') { e.preventDefault(); stepTime(v, stepSize()); }
    else if (e.key === 'ArrowLeft') { e.preventDefault(); stepTime(v, -stepSize()); }
    else if (e.key === '.') stepFrame(v, 1);
    else if (e.key === ',') stepFrame(v, -1);
    else if ('wasdqe'.includes(e.key.toLowerCase())) v.held.add(e.key.toLowerCase());
  });
  window.addEventListener('keyup', (e) => v.held.delete(e.key.toLowerCase()));
}

function currentView(v) {
  return v.state.camera !== null ? sceneView(v.manifest.cameras[v.state.camera])
                                 : v.navigator.view(canvas.width, canvas.height);
}
const keyOf = (v, view) => JSON.stringify([v.state.t, view.rotation, view.translation, view.width,
                                           view.height, view.fx, view.fy, view.cx, view.cy]);

// The frame loop: the worker's orders come back to the renderer, each animation frame runs tick,
// and window.retimegs gets setTime and state.
function runFrameLoop(v) {
  v.lastTime = performance.now(), v.fpsSince = v.lastTime;
  v.worker.onmessage = (e) => {
    v.busy = false;
    v.renderer.setOrder(e.data.order);
    api.sortMs = e.data.ms;
    api.visible = e.data.order.length;
    v.sortedKey = v.pendingKey;
    v.dirty = true;
  };
  v.worker.onerror = (e) => showMessage(`sort worker: ${e.message}`);
  const tick = (now) => {
    const elapsed = Math.min(0.25, (now - v.lastTime) / 1000);
    v.lastTime = now;
    advance(v, elapsed);
    const view = currentView(v);
    const key = keyOf(v, view);
    requestSort(v, view, key);
    draw(v, view, key);
    showStatus(v, now);
    requestAnimationFrame(tick);
  };
  api.setTime = (t) => { v.state.playing = false; setTime(v, t); };
  api.state = () => ({ t: v.state.t, playing: v.state.playing, speed: v.state.speed,
                       camera: v.state.camera === null ? null
                                                       : v.manifest.cameras[v.state.camera].name,
                       width: canvas.width, height: canvas.height });
  layout(v);
  requestAnimationFrame(tick);
}

// Playback and flight over `elapsed` seconds: the time runs at fps × speed (looping or stopping at
// the end), held fly keys move the free camera.
function advance(v, elapsed) {
  const state = v.state;
  if (state.playing) {
    let t = state.t + elapsed * v.fps * state.speed;
    if (t > v.last) {
      if (state.loop && v.last > v.first) t = v.first + ((t - v.first) % (v.last - v.first));
      else t = v.last, state.playing = false;
    }
    state.t = t;
    changed(v);
  }
  const held = v.held;
  if (held.size) {
    leaveCamera(v);
    const s = elapsed;
    v.navigator.fly((held.has('w') - held.has('s')) * s, (held.has('d') - held.has('a')) * s,
                    (held.has('e') - held.has('q')) * s);
    changed(v);
  }
}

// Asks the idle worker for the depth order of the state `key` shows.
function requestSort(v, view, key) {
  if (v.busy || key === v.sortedKey) return;
  v.busy = true;
  v.pendingKey = key;
  v.worker.postMessage({ type: 'sort', id: ++v.requestId, t: v.state.t,
                         zRow: view.rotation.slice(6, 9), tz: view.translation[2],
                         near: v.manifest.near });
}

// Draws the current state once some order has come back; frameReady turns true on the next
// animation frame (when the compositor has taken this one) if the order was this state's and
// nothing changed since.
function draw(v, view, key) {
  if (!v.dirty || v.sortedKey === null) return;
  v.renderer.draw(view, v.state.t, v.manifest.background);
  v.dirty = false;
  ++v.frames;
  if (key !== v.sortedKey) return;
  requestAnimationFrame(() => {
    if (keyOf(v, currentView(v)) === key && !v.dirty) {
      api.frameReady = true;
      if (v.firstFrame) {
        // Reading a pixel waits for the GPU to finish the frame.
        v.firstFrame = false;
        const gl = v.renderer.gl;
        gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
        api.loadMs = performance.now();  // since the navigation started
      }
    }
  });
}

// The frame rate, the slider, the play button, the time label and the heads-up line.
function showStatus(v, now) {
  if (now - v.fpsSince >= 1000) {
    v.fpsShown = (v.frames * 1000) / (now - v.fpsSince);
    v.frames = 0, v.fpsSince = now;
  }
  const state = v.state;
  slider.value = state.t;
  playButton.textContent = state.playing ? 'II' : '▶';
  const atTraining = v.training.has(Math.round(state.t * 1e6));
  timeLabel.textContent = `t = ${state.t.toFixed(3)}${atTraining ? ' (training)' : ''}`;
  hud.textContent = `${v.fpsShown.toFixed(1)} fps · ${api.visible.toLocaleString('en')} / ` +
                    `${v.manifest.count.toLocaleString('en')} visible · ` +
                    `sort ${api.sortMs?.toFixed(1) ?? '–'} ms`;
}

load().catch((error) => showMessage(`retimegs viewer: ${error.message}`));
