// rmpmarl view's page: connects to /ws, draws the latest hello and frame, and sends what the user does
// (protocol: docs/viewer.md). window.__rmpmarlViewer is the hook the browser test reads.
import { Connection } from './connection.js';
import { SceneView } from './scene.js';
import { DragController } from './drag.js';
import { Panel } from './panel.js';
import { Plots } from './plots.js';
import { Recorder } from './recorder.js';
import { ARM_COLOR, SECOND_ARM_COLOR } from './colors.js';

const $ = (id) => document.getElementById(id);
const JOINT_TABLE_INTERVAL_MS = 100;

const state = {
  hello: null,
  helloText: null,
  frame: null,
  frames: 0,
  fps: 0,
  drawFps: 0,
  errors: [],
  selected: null,
  added: 0,
};

// the 3D view needs WebGL; without it the panel, the plots and the controls still work
let view = null;
try {
  view = new SceneView($('scene'), $('labels'));
} catch (e) {
  console.error('rmpmarl view: no 3D view', e);
  $('hint').textContent = `WebGL is not available in this browser, so there is no 3D view (${e.message}); `
    + 'the panel still works.';
  $('hint').classList.add('warning');
}
const plots = new Plots($('plots'), $('legend'));
const recorder = new Recorder((why) => {
  toast(`recording stopped: ${why}; downloaded`);
  updateRecordButton();
});

const connection = new Connection(`ws://${location.host}/ws`, {
  open() {
    $('banner').hidden = true;
  },
  close() {
    $('banner').hidden = false;
    if (recorder.active) {
      recorder.stop();
      toast('recording stopped: disconnected; downloaded');
      updateRecordButton();
    }
  },
  message(m, text) {
    if (m.type === 'hello') onHello(m, text);
    else if (m.type === 'frame') onFrame(m, text);
    else if (m.type === 'error') {
      state.errors.push(String(m.message));
      if (state.errors.length > 100) state.errors.shift();
      toast(String(m.message), 'error');
    }
  },
});
const send = (obj) => connection.send(obj);

const panel = new Panel(send, {
  addObstacle(shape) {
    // in front of the arm: the middle of the workspace, then alternately to its sides
    const ws = state.hello && state.hello.workspace;
    if (!ws) return;
    const k = state.added++ % 5;
    const dy = [0, 1, -1, 2, -2][k] * 0.15;
    const p = ws.min.map((lo, i) => 0.5 * (lo + ws.max[i]));
    p[1] = Math.max(ws.min[1], Math.min(ws.max[1], p[1] + dy));
    send({ type: 'add_obstacle', shape, p });
  },
  removeSelected() {
    if (state.selected === null || (state.hello && state.hello.mode === 'replay')) return;
    send({ type: 'remove_obstacle', id: state.selected });
    select(null);
  },
  toggleRecord() {
    if (recorder.active) {
      const n = recorder.stop();
      toast(`recorded ${n} frames; downloaded`);
    } else if (state.helloText) {
      recorder.start(state.helloText);
    }
    updateRecordButton();
  },
});

const drag = view && new DragController(view, send, {
  canSteer: () => !!state.hello && state.hello.mode !== 'replay',
  onSelect: (id) => select(id),
  arena: () => (state.hello && state.hello.limits && state.hello.limits.arena) || 5,
});

function select(id) {
  state.selected = id;
  if (view) view.select(id);
  $('remove').disabled = id === null || !state.hello || state.hello.mode === 'replay';
}

function onHello(hello, text) {
  state.hello = hello;
  state.helloText = text;
  if (view) view.setHello(hello);
  panel.setHello(hello);
  plots.setArms(hello.arms.map((a) => a.label), [ARM_COLOR, SECOND_ARM_COLOR]);
  recorder.onHello(text, hello);
  select(state.selected);
}

let lastJointTable = 0;
function onFrame(frame, text) {
  state.frame = frame;
  state.frames += 1;
  if (view) view.setFrame(frame);
  if (drag) drag.onFrame(frame);
  panel.setFrame(frame);
  plots.push(frame);
  recorder.onFrame(text, frame);
  if (state.selected !== null && !frame.obstacles.some((o) => o.id === state.selected)) select(null);
  const now = performance.now();
  if (now - lastJointTable > JOINT_TABLE_INTERVAL_MS) {
    lastJointTable = now;
    panel.updateJoints(frame);
  }
  updateRecordButton();
}

function updateRecordButton() {
  const b = $('record');
  const text = recorder.active ? `Stop recording (${recorder.frames.length})` : 'Record';
  if (b.textContent !== text) b.textContent = text;
  b.classList.toggle('on', recorder.active);
}

function toast(message, kind = 'info') {
  const el = document.createElement('div');
  el.className = `toast ${kind}`;
  el.textContent = message.length > 200 ? `${message.slice(0, 197)}...` : message;
  const box = $('toasts');
  box.appendChild(el);
  while (box.children.length > 4) box.firstChild.remove();
  setTimeout(() => { el.style.opacity = '0'; }, 3000);
  setTimeout(() => el.remove(), 3500);
}

function statusLine() {
  const f = state.frame;
  const fmt = (x, d) => (typeof x === 'number' && Number.isFinite(x) ? x.toFixed(d) : '–');
  const lines = [];
  if (f) {
    lines.push(`t ${fmt(f.t, 2)} s${f.paused ? ' (paused)' : ''} · speed ${f.speed}× · rtf ${fmt(f.rtf, 2)}`
      + ` · load ${fmt(100 * f.load, 0)}%`);
    lines.push(`page ${state.drawFps} draws/s (${state.fps} fps) · refused ${f.refused} · obstacles ${f.obstacles.length}`
      + `${f.target.held ? ' · target held' : ''}`);
    for (const [i, a] of f.arms.entries()) {
      lines.push(`arm ${i + 1}: error ${fmt(1000 * a.error, 0)} mm · clearance `
        + `${a.clearance === null ? '–' : fmt(1000 * a.clearance, 0) + ' mm'} · collisions ${a.collisions}`
        + ` · step ${fmt(a.step_us, 0)} µs`);
    }
  } else {
    lines.push(`page ${state.fps} fps · waiting for frames`);
  }
  return lines.join('\n');
}

// the animation loop; fps counts the animation frames of the last second, drawFps the ones that drew the scene (it
// is drawn only when a frame, the camera, the selection or a drag changed it)
const frameTimes = [], drawTimes = [];
function animate(now) {
  frameTimes.push(now);
  while (frameTimes.length && frameTimes[0] <= now - 1000) frameTimes.shift();
  state.fps = frameTimes.length;
  if (view && view.render()) drawTimes.push(now);
  while (drawTimes.length && drawTimes[0] <= now - 1000) drawTimes.shift();
  state.drawFps = drawTimes.length;
  plots.draw();
  panel.setStatus(statusLine());
  requestAnimationFrame(animate);
}
requestAnimationFrame(animate);

window.__rmpmarlViewer = {
  get hello() { return state.hello; },
  get frame() { return state.frame; },
  get frames() { return state.frames; },
  get fps() { return state.fps; },
  get drawFps() { return state.drawFps; },
  // true: draw the scene at every animation frame, changed or not (a measurement of the browser's drawing rate)
  get continuous() { return view ? view.continuous : false; },
  set continuous(on) { if (view) view.continuous = !!on; },
  get errors() { return state.errors.slice(); },
  get connected() { return connection.connected; },
  get selected() { return state.selected; },
  get recording() { return recorder.active; },
  get lastDrag() { return drag ? drag.lastSent : null; },
  armColor: ARM_COLOR.slice(),
  project: (p) => (view ? view.project(p) : null),
  countPixels: (rgb, tol = 0) => (view ? view.countPixels(rgb, tol) : 0),
  obstacleMeshes: () => (view ? view.obstacleMeshes() : []),
  send: (obj) => connection.send(obj),
};
