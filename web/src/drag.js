// Left-button dragging of the target and the obstacles: the object moves in the plane through the grabbed point
// facing the camera (Shift: the vertical plane facing it), and the server hears set_target / set_obstacle at most
// every 30 ms and once more on release. A click on an obstacle selects it; a click on nothing clears the selection.
import * as THREE from 'three';

const SEND_INTERVAL_MS = 30;
const CONFIRM_TIMEOUT_MS = 500;  // how long the dragged position is shown after release if no frame confirms it

export class DragController {
  // view: SceneView; send(obj); options: {canSteer() → bool, onSelect(id|null), arena() → metres}
  constructor(view, send, options) {
    this.view = view;
    this.send = send;
    this.options = options;
    this.drag = null;
    this.lastSentAt = 0;
    this.lastSent = null;  // the last message a drag sent
    this.timer = null;
    this.releaseTimer = null;
    const canvas = view.canvas;
    canvas.addEventListener('pointerdown', (e) => this.down(e));
    canvas.addEventListener('pointermove', (e) => this.move(e));
    canvas.addEventListener('pointerup', (e) => this.up(e));
    canvas.addEventListener('pointercancel', (e) => this.up(e));
    window.addEventListener('keydown', (e) => { if (e.key === 'Shift' && this.drag) this.replan(true); });
    window.addEventListener('keyup', (e) => { if (e.key === 'Shift' && this.drag) this.replan(false); });
  }

  get active() { return this.drag !== null; }

  down(e) {
    if (e.button !== 0 || this.drag) return;
    const hit = this.view.pick(e.clientX, e.clientY);
    if (hit === null) {
      this.options.onSelect(null);
      return;
    }
    if (hit.kind === 'obstacle') this.options.onSelect(hit.id);
    if (!this.options.canSteer()) return;
    e.preventDefault();
    this.view.canvas.setPointerCapture(e.pointerId);
    this.drag = {
      kind: hit.kind, id: hit.id, pointerId: e.pointerId,
      offset: hit.centre.clone().sub(hit.point),  // centre − grabbed point
      grab: hit.point.clone(), p: hit.centre.clone(), moved: false,
      vertical: e.shiftKey, plane: new THREE.Plane(),
    };
    this.makePlane(hit.point);
    this.view.canvas.style.cursor = 'grabbing';
  }

  // the drag plane through `point`: facing the camera, or vertical and facing it.
  makePlane(point) {
    const n = new THREE.Vector3();
    this.view.camera.getWorldDirection(n);
    if (this.drag.vertical) {
      n.z = 0;
      if (n.lengthSq() < 1e-8) n.set(1, 0, 0);
    }
    this.drag.plane.setFromNormalAndCoplanarPoint(n.normalize(), point);
  }

  replan(vertical) {
    if (this.drag.vertical === vertical) return;
    this.drag.vertical = vertical;
    this.makePlane(this.drag.p.clone().sub(this.drag.offset));
  }

  move(e) {
    const d = this.drag;
    if (!d || e.pointerId !== d.pointerId) return;
    if (e.shiftKey !== d.vertical) this.replan(e.shiftKey);
    const ray = this.view.rayAt(e.clientX, e.clientY);
    const point = new THREE.Vector3();
    if (ray.intersectPlane(d.plane, point) === null) return;
    const limit = this.options.arena() - 1e-3;
    d.p.copy(point).add(d.offset).clampScalar(-limit, limit);
    d.moved = true;
    this.view.setOverride({ kind: d.kind, id: d.id, p: d.p.toArray() });
    const wait = this.lastSentAt + SEND_INTERVAL_MS - performance.now();
    if (wait <= 0) {
      this.flush();
    } else if (this.timer === null) {
      this.timer = setTimeout(() => { this.timer = null; if (this.drag) this.flush(); }, wait);
    }
  }

  up(e) {
    const d = this.drag;
    if (!d || e.pointerId !== d.pointerId) return;
    if (this.timer !== null) { clearTimeout(this.timer); this.timer = null; }
    if (d.moved) this.flush();
    this.drag = null;
    this.view.canvas.style.cursor = '';
    if (this.view.canvas.hasPointerCapture(e.pointerId)) this.view.canvas.releasePointerCapture(e.pointerId);
    // keep showing where it was left until a frame confirms it (or a while has passed)
    if (!d.moved) { this.view.setOverride(null); return; }
    this.pendingRelease = { kind: d.kind, id: d.id, p: d.p.toArray() };
    clearTimeout(this.releaseTimer);
    this.releaseTimer = setTimeout(() => this.clearOverride(), CONFIRM_TIMEOUT_MS);
  }

  // called for every frame: ends the post-release override once the frame shows the object where it was left.
  onFrame(frame) {
    const r = this.pendingRelease;
    if (!r || this.drag) return;
    const p = r.kind === 'target' ? frame.target.p
      : (frame.obstacles.find((o) => o.id === r.id) || {}).p;
    if (!p || Math.hypot(p[0] - r.p[0], p[1] - r.p[1], p[2] - r.p[2]) < 2e-3) this.clearOverride();
  }

  clearOverride() {
    this.pendingRelease = null;
    clearTimeout(this.releaseTimer);
    if (!this.drag) this.view.setOverride(null);
  }

  flush() {
    const d = this.drag;
    this.lastSentAt = performance.now();
    const p = d.p.toArray().map((x) => Math.round(x * 1e5) / 1e5);
    const message = d.kind === 'target' ? { type: 'set_target', p } : { type: 'set_obstacle', id: d.id, p };
    this.send(message);
    this.lastSent = message;
  }
}
