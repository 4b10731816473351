// Cameras in the project's convention (OpenCV: x right, y down, z forward; docs/formats.md): a
// view is a world-to-camera rotation (row-major) and translation with pinhole intrinsics. Free
// navigation keeps an eye, a heading (yaw, pitch about the scene's `up`) and a target distance;
// orbit turns about the target, fly turns about the eye.

const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                         a[0] * b[1] - a[1] * b[0]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const normalize = (a) => scale(a, 1 / Math.hypot(a[0], a[1], a[2]));

// A scene camera of model.json as a view.
export function sceneView(camera) {
  const m = camera.world_to_camera;
  const rotation = [m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]];
  const translation = [m[3], m[7], m[11]];
  return withEye({ rotation, translation, fx: camera.fx, fy: camera.fy, cx: camera.cx,
                   cy: camera.cy, width: camera.width, height: camera.height,
                   color: camera.color || null });
}

// The camera centre -Rᵀ t.
function withEye(view) {
  const r = view.rotation, t = view.translation;
  view.eye = [0, 1, 2].map((c) => -(r[c] * t[0] + r[3 + c] * t[1] + r[6 + c] * t[2]));
  return view;
}

export class Navigator {
  constructor(up, centre, radius) {
    this.up = normalize(up);
    // A basis of the plane orthogonal to up, for the heading.
    const helper = Math.abs(this.up[0]) < 0.9 ? [1, 0, 0] : [0, 1, 0];
    this.e1 = normalize(cross(this.up, helper));
    this.e2 = cross(this.up, this.e1);
    this.target = centre.slice();
    this.distance = 2.5 * radius;
    this.radius = radius;
    this.yaw = 0;
    this.pitch = 0.3;
    this.eye = sub(this.target, scale(this.forward(), this.distance));
    this.verticalFov = (50 * Math.PI) / 180;
  }

  forward() {
    const c = Math.cos(this.pitch);
    const horizontal = add(scale(this.e1, c * Math.cos(this.yaw)), scale(this.e2, c * Math.sin(this.yaw)));
    return normalize(add(horizontal, scale(this.up, -Math.sin(this.pitch))));
  }

  // Takes over from a view (a scene camera): same eye and direction, target at the scene centre's
  // depth, the field of view of its height.
  setFromView(view, centre) {
    const f = [view.rotation[6], view.rotation[7], view.rotation[8]];
    this.eye = view.eye.slice();
    this.pitch = Math.asin(Math.max(-1, Math.min(1, -dot(f, this.up))));
    this.yaw = Math.atan2(dot(f, this.e2), dot(f, this.e1));
    this.distance = Math.max(dot(sub(centre, this.eye), f), 0.1 * this.radius);
    this.target = add(this.eye, scale(this.forward(), this.distance));
    this.verticalFov = 2 * Math.atan(view.height / 2 / view.fy);
  }

  orbit(dx, dy) {
    this.yaw -= dx * 0.005;
    this.pitch = Math.max(-1.5, Math.min(1.5, this.pitch + dy * 0.005));
    this.eye = sub(this.target, scale(this.forward(), this.distance));
  }

  look(dx, dy) {
    this.yaw -= dx * 0.003;
    this.pitch = Math.max(-1.5, Math.min(1.5, this.pitch + dy * 0.003));
    this.target = add(this.eye, scale(this.forward(), this.distance));
  }

  pan(dx, dy) {
    const { right, down } = this.axes();
    const s = (this.distance * 0.0015);
    const move = add(scale(right, -dx * s), scale(down, -dy * s));
    this.eye = add(this.eye, move);
    this.target = add(this.target, move);
  }

  zoom(factor) {
    this.distance = Math.max(1e-3 * this.radius, this.distance * factor);
    this.eye = sub(this.target, scale(this.forward(), this.distance));
  }

  // Fly: move the eye (and the target with it) along the view axes, in units of the radius.
  fly(forwardAmount, rightAmount, upAmount) {
    const { right } = this.axes();
    const s = this.radius;
    const move = add(add(scale(this.forward(), forwardAmount * s), scale(right, rightAmount * s)),
                     scale(this.up, upAmount * s));
    this.eye = add(this.eye, move);
    this.target = add(this.target, move);
  }

  axes() {
    const z = this.forward();
    let x = cross(z, this.up);  // core/camera.cpp look_at: x = z × up, y = z × x (down)
    if (Math.hypot(...x) < 1e-9) x = this.e1;
    x = normalize(x);
    return { right: x, down: cross(z, x), forward: z };
  }

  // The view at a canvas of width x height pixels.
  view(width, height) {
    const { right, down, forward } = this.axes();
    const rotation = [...right, ...down, ...forward];
    const translation = [-dot(right, this.eye), -dot(down, this.eye), -dot(forward, this.eye)];
    const f = height / 2 / Math.tan(this.verticalFov / 2);
    return withEye({ rotation, translation, fx: f, fy: f, cx: width / 2, cy: height / 2, width,
                     height, color: null });
  }
}
