// The side panel: controls that send commands, the set-up line, the status line and the per-joint tables.
import { ARM_COLOR, OPTION_COLORS, css } from './colors.js';

const $ = (id) => document.getElementById(id);

export class Panel {
  // send(obj); actions: {addObstacle(shape), removeSelected(), toggleRecord()}
  constructor(send, actions) {
    this.send = send;
    this.hello = null;
    this.paused = false;
    this.cells = [];  // per arm, per joint: {option, params[4]}

    $('pause').addEventListener('click', () => send({ type: this.paused ? 'resume' : 'pause' }));
    $('step').addEventListener('click', () => send({ type: 'step' }));
    $('reset').addEventListener('click', () => send({ type: 'reset' }));
    $('speed').addEventListener('change', (e) => send({ type: 'speed', value: Number(e.target.value) }));
    $('controller').addEventListener('change', (e) => send({ type: 'controller', name: e.target.value }));
    $('side-by-side').addEventListener('change', (e) => send({ type: 'side_by_side', on: e.target.checked }));
    $('add-box').addEventListener('click', () => actions.addObstacle('box'));
    $('add-sphere').addEventListener('click', () => actions.addObstacle('sphere'));
    $('remove').addEventListener('click', () => actions.removeSelected());
    $('release-target').addEventListener('click', () => send({ type: 'release_target' }));
    $('record').addEventListener('click', () => actions.toggleRecord());
    $('seek').addEventListener('input', (e) => {
      const now = performance.now();
      if (now - (this.lastSeek || 0) < 30) return;
      this.lastSeek = now;
      send({ type: 'seek', frame: Number(e.target.value) });
    });
    $('seek').addEventListener('change', (e) => send({ type: 'seek', frame: Number(e.target.value) }));
    window.addEventListener('keydown', (e) => {
      if ((e.key === 'Delete' || e.key === 'Backspace') && !/INPUT|SELECT|TEXTAREA/.test(e.target.tagName)) {
        actions.removeSelected();
      }
    });
  }

  get replay() { return this.hello !== null && this.hello.mode === 'replay'; }

  setHello(hello) {
    this.hello = hello;
    const replay = this.replay;
    const select = $('controller');
    select.replaceChildren(...(hello.controllers || []).map((name) => new Option(name, name)));
    // the first arm's controller (side by side, hello.controller may name the one the first arm returns to)
    const first = (hello.arms[0] && hello.arms[0].controller) || hello.controller;
    if (first) select.value = first;
    select.disabled = replay || hello.side_by_side || (hello.controllers || []).length < 2;
    const sbs = $('side-by-side');
    sbs.checked = !!hello.side_by_side;
    sbs.disabled = replay || !(hello.controllers || []).includes('learned');
    for (const id of ['add-box', 'add-sphere', 'release-target']) $(id).disabled = replay;
    // a replay cannot be steered: no controls for it
    for (const el of document.querySelectorAll('.steer')) el.hidden = replay;
    if (!$('hint').classList.contains('warning')) $('hint').textContent = replay
      ? 'replay: steering is off · right-drag: orbit · wheel: zoom'
      : 'left-drag: move target / obstacle (Shift: vertically) · right-drag: orbit · wheel: zoom · Delete: remove selected';
    $('replay-row').hidden = !replay;
    $('seek').hidden = !replay;
    if (replay && hello.replay) $('seek').max = String(Math.max(0, hello.replay.frames - 1));
    $('step').title = replay ? 'one frame while paused' : 'one control step while paused';
    const speed = $('speed'), shown = speed.value;
    speed.replaceChildren(...speedChoices(hello).map((s) => new Option(`${s}×`, String(s))));
    if ([...speed.options].some((o) => o.value === shown)) speed.value = shown;

    const r = hello.robot;
    $('setup').textContent = `${r.name} (${r.nq} joints) · ${hello.mode === 'replay' ? 'replay' : 'live'}`
      + ` · scenario ${hello.scenario ?? '?'} · seed ${hello.seed ?? '?'} · ${hello.control_rate ?? '?'} Hz`;
    this.buildJointTables(hello);
  }

  buildJointTables(hello) {
    const root = $('joints');
    const nodes = [];
    this.cells = [];
    if (hello.arms.some((a) => a.controller === 'learned')) {
      // what the link colours mean
      const legend = document.createElement('div');
      legend.className = 'option-legend';
      for (const name of [...(hello.options || []), 'idle']) {
        const item = document.createElement('span');
        const sw = document.createElement('span');
        sw.className = 'swatch';
        sw.style.background = OPTION_COLORS[name] ? css(OPTION_COLORS[name]) : css(ARM_COLOR);
        item.append(sw, name);
        legend.appendChild(item);
      }
      nodes.push(legend);
    }
    hello.arms.forEach((arm, i) => {
      const title = document.createElement('div');
      title.className = 'arm-title';
      title.textContent = `${hello.arms.length > 1 ? (i === 0 ? 'Arm 1' : 'Arm 2 (translucent)') : 'Arm'}: `
        + `${arm.label} (${arm.controller})`;
      nodes.push(title);
      if (arm.controller !== 'learned') {
        const note = document.createElement('div');
        note.className = 'note';
        note.textContent = 'RMPflow has no agents: no options or parameters to show.';
        nodes.push(note);
        this.cells.push(null);
        return;
      }
      const table = document.createElement('table');
      table.className = 'joints';
      const head = table.createTHead().insertRow();
      for (const h of ['joint', 'option', ...(hello.parameters || [])]) {
        const th = document.createElement('th');
        th.textContent = h;
        head.appendChild(th);
      }
      const body = table.createTBody();
      const rows = hello.robot.joints.map((name) => {
        const tr = body.insertRow();
        tr.insertCell().textContent = name.replace(/^.*_joint/, 'joint ');
        const option = tr.insertCell();
        const params = (hello.parameters || []).map(() => {
          const td = tr.insertCell();
          td.className = 'num';
          return td;
        });
        return { option, params, last: '' };
      });
      nodes.push(table);
      this.cells.push(rows);
    });
    root.replaceChildren(...nodes);
  }

  setFrame(frame) {
    this.paused = !!frame.paused;
    const pause = $('pause');
    const label = this.paused ? 'Resume' : 'Pause';
    if (pause.textContent !== label) pause.textContent = label;
    const speed = $('speed');
    if (document.activeElement !== speed && Number(speed.value) !== frame.speed) {
      const option = [...speed.options].find((o) => Math.abs(Number(o.value) - frame.speed) < 1e-9);
      if (option) speed.value = option.value;
    }
    $('release-target').disabled = this.replay || !frame.target.held;
    if (this.replay && document.activeElement !== $('seek') && Number.isInteger(frame.index)) {
      $('seek').value = String(frame.index);
      $('seek-label').textContent = `frame ${frame.index + 1} / ${this.hello.replay ? this.hello.replay.frames : '?'}`;
    }
  }

  // the per-joint tables (called a few times per second: they are text).
  updateJoints(frame) {
    if (!this.hello) return;
    (frame.arms || []).forEach((arm, i) => {
      const rows = this.cells[i];
      if (!rows || !arm.joints) return;
      rows.forEach((row, j) => {
        const a = arm.joints[j];
        if (!a) return;
        const name = a.option >= 0 ? (this.hello.options[a.option] ?? `option ${a.option}`) : 'idle';
        const composite = name === 'target-then-collision';
        const key = composite ? `${name}, phase ${a.phase_b ? 'b (collision)' : 'a (target)'}` : name;
        if (row.last !== key) {
          row.last = key;
          row.option.replaceChildren();
          row.option.title = key;
          const sw = document.createElement('span');
          sw.className = 'swatch';
          sw.style.background = OPTION_COLORS[name] ? css(OPTION_COLORS[name]) : i === 0 ? css(ARM_COLOR) : 'transparent';
          row.option.append(sw, composite ? `t→c (${a.phase_b ? 'coll.' : 'target'})` : name);
        }
        row.params.forEach((td, k) => {
          const v = a.params[k];
          td.textContent = typeof v === 'number' ? v.toFixed(2) : '–';
        });
      });
    });
  }

  setStatus(text) {
    const el = $('status');
    if (el.textContent !== text) el.textContent = text;
  }
}

// the speeds the page offers: 0.1, 0.25, 0.5 and 1 within the hello's limits.
function speedChoices(hello) {
  const [lo, hi] = (hello.limits && hello.limits.speeds) || [0.1, 1];
  const choices = [0.1, 0.25, 0.5, 1].filter((s) => s >= lo - 1e-9 && s <= hi + 1e-9);
  return choices.length ? choices : [hi];
}
