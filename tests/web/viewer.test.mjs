// Browser test of `rmpmarl view` (docs/viewer.md): starts the server, opens its page in headless Chromium
// (software WebGL) and checks that the arm is drawn, that dragging the target steers the arm, that the controller
// and side-by-side switches work, that bad messages are refused (and a flood of them does not stop the simulation),
// that a reset starts a new episode; it measures the page's frame rate and the server's real-time factor, plays the
// page's recording back with `--replay`, restarts the server under the page, and draws a MoveIt planning scene
// (`--scene`: a cylinder and a box, their sizes and poses checked on the page's meshes). Exit code 0: every step passed.
// Screenshots, the server's and the page's logs and the recording are left in the --out directory.
//
// usage: node tests/web/viewer.test.mjs --rmpmarl build/rmpmarl --out build/test-artifacts/web [--web-root DIR]
//   (--web-root: the page to serve, passed on to `rmpmarl view`; default: the server's own)
//   (playwright-core is resolved from web/node_modules: run `npm ci` in web/ first)
import { spawn } from 'node:child_process';
import { createRequire } from 'node:module';
import fs from 'node:fs';
import http from 'node:http';
import net from 'node:net';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const HERE = path.dirname(fileURLToPath(import.meta.url));
const WEB = path.resolve(HERE, '../../web');
const CHROMIUM = '/usr/bin/chromium';
const CHROMIUM_ARGS = [
  '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking',
  '--disable-component-update', '--disable-sync',
  // WebGL without a GPU: ANGLE on SwiftShader, asked for (Chromium's automatic fallback to it is deprecated)
  '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
];
const VIEWPORT = { width: 1280, height: 800 };
const TOTAL_TIMEOUT_MS = 120_000;   // a hung server or browser fails the test instead of blocking ctest
const ARM_COLOR_TOL = 40;           // per channel: the arm's shading keeps most of its pixels this close
const MIN_ARM_PIXELS = 300;
const TRACK_TOL = 0.02;             // [m]
const TRACK_TIME_MS = 3000;
const DRAG_DISTANCE = 0.15;         // [m]
const POSE_TOL = 1e-3;              // [m], and for unit axes
const SIZE_TOL = 1e-4;              // [m]: the frames carry sizes to 4 decimals

// the MoveIt planning scene of step 8. MoveIt's cylinder is [height, radius] along the primitive's z axis; this
// orientation (x, y, z, w) turns it 90° about x, so its axis lies along world −y.
const SCENE_YAML = `world:
  collision_objects:
    - id: can
      primitive_poses:
        - position: [0.5, 0.2, 0.3]
          orientation: [0.7071067811865476, 0, 0, 0.7071067811865476]
      primitives:
        - type: cylinder
          dimensions: [0.3, 0.05]
    - id: board
      primitive_poses:
        - position: [0.5, -0.3, 0.2]
          orientation: [0, 0, 0, 1]
      primitives:
        - type: box
          dimensions: [0.2, 0.1, 0.02]
`;

// ---------------------------------------------------------------- arguments, reporting

function parseArgs(argv) {
  const opts = {};
  for (let i = 0; i < argv.length; ++i) {
    const a = argv[i];
    if (a === '--rmpmarl' || a === '--out' || a === '--web-root') opts[a.slice(2)] = argv[++i];
    else throw new Error(`unknown argument ${a}`);
  }
  if (!opts.rmpmarl || !opts.out) {
    throw new Error('usage: node tests/web/viewer.test.mjs --rmpmarl <path to rmpmarl> --out <artefact dir> '
      + '[--web-root <built page>]');
  }
  return opts;
}

const results = [];
function report(ok, name, details) {
  results.push({ ok, name });
  console.log(`${ok ? 'PASS' : 'FAIL'} ${name}${details ? ': ' + details : ''}`);
}

class Failure extends Error {}
function check(condition, message) {
  if (!condition) throw new Failure(message);
}

// runs one step: PASS with the details it returns, FAIL with the reason; a fatal step ends the test.
let currentStep = 'start-up';
async function step(name, fn, { fatal = false } = {}) {
  const t0 = Date.now();
  currentStep = name;
  try {
    const details = await fn();
    report(true, name, `${details ?? ''} [${((Date.now() - t0) / 1000).toFixed(1)} s]`);
    return true;
  } catch (e) {
    report(false, name, `${e instanceof Failure ? e.message : (e && e.stack) || String(e)} `
      + `${exits.length ? `(${exits.join('; ')}) ` : ''}[${((Date.now() - t0) / 1000).toFixed(1)} s]`);
    if (fatal) throw new Failure(`${name} failed; later steps need it`);
    return false;
  }
}

const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));
const dist = (a, b) => Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
const fmt = (x, d = 3) => (typeof x === 'number' && Number.isFinite(x) ? x.toFixed(d) : String(x));
const vec = (p) => `[${p.map((x) => fmt(x, 3)).join(', ')}]`;

// polls fn (in the page) until it returns a truthy value; throws with `what` after timeoutMs.
async function waitInPage(page, fn, arg, timeoutMs, what) {
  const t0 = Date.now();
  for (;;) {
    const v = await page.evaluate(fn, arg);
    if (v) return { value: v, ms: Date.now() - t0 };
    if (Date.now() - t0 > timeoutMs) throw new Failure(`${what}: not within ${timeoutMs} ms`);
    await sleep(50);
  }
}

// ---------------------------------------------------------------- the server

// servers that have exited, for the messages of failed steps
const exits = [];

// starts `rmpmarl view --port PORT [extra]`; its url resolves once it has printed it.
function startServer(rmpmarl, extra, logPath, port = 0) {
  const proc = spawn(rmpmarl, ['view', '--port', String(port), ...extra], { stdio: ['ignore', 'pipe', 'pipe'] });
  const log = fs.createWriteStream(logPath);
  let stdout = '', output = '';
  const url = new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Failure(`no URL printed within 30 s; output:\n${output.slice(-2000)}`)),
      30_000);
    proc.stdout.on('data', (d) => {
      stdout += d;
      output += d;
      log.write(d);
      const m = /http:\/\/[^\s'"<>]+/.exec(stdout);
      if (m) { clearTimeout(timer); resolve(m[0].endsWith('/') ? m[0] : m[0] + '/'); }
    });
    proc.stderr.on('data', (d) => { output += d; log.write(d); });
    proc.on('error', (e) => { clearTimeout(timer); reject(new Failure(`cannot start ${rmpmarl}: ${e.message}`)); });
    proc.on('exit', (code, signal) => {
      exits.push(`${path.basename(rmpmarl)} view ${extra.join(' ')} exited (${code ?? signal})`);
      clearTimeout(timer);
      reject(new Failure(`${rmpmarl} view exited (${code ?? signal}) before printing a URL; output:\n`
        + output.slice(-2000)));
    });
  });
  return { proc, url, output: () => output };
}

async function stopServer(server) {
  if (!server || server.proc.exitCode !== null || server.proc.signalCode !== null) return;
  const exited = new Promise((resolve) => server.proc.once('exit', resolve));
  server.proc.kill('SIGTERM');
  const timer = setTimeout(() => server.proc.kill('SIGKILL'), 3000);
  await exited;
  clearTimeout(timer);
}

// raw TCP: connects to the server, writes `data`, and destroys the socket after `ms` (no goodbye).
function abruptSocket(port, data, ms) {
  return new Promise((resolve) => {
    const s = net.connect(port, '127.0.0.1', () => {
      if (data) s.write(data);
      setTimeout(() => { s.destroy(); resolve(); }, ms);
    });
    s.on('data', () => {});
    s.on('error', () => resolve());
  });
}

// GET of a raw (not normalised) path: {status, body}.
function httpGet(port, rawPath) {
  return new Promise((resolve, reject) => {
    const req = http.get({ host: '127.0.0.1', port, path: rawPath, timeout: 5000 }, (res) => {
      let body = '';
      res.setEncoding('utf8');
      res.on('data', (d) => { body += d; });
      res.on('end', () => resolve({ status: res.statusCode, type: res.headers['content-type'], body }));
    });
    req.on('timeout', () => req.destroy(new Error(`GET ${rawPath}: no answer within 5 s`)));
    req.on('error', reject);
  });
}

// ---------------------------------------------------------------- the bad messages of the fuzz step

// a deterministic generator (the test is reproducible).
function lcg(seed) {
  let s = seed >>> 0;
  return () => { s = (Math.imul(s, 1664525) + 1013904223) >>> 0; return s / 2 ** 32; };
}

// text messages the server must refuse (each one).
function badTextMessages() {
  const rnd = lcg(12345);
  const m = [];
  // not JSON
  m.push('not json', '{', '}', '[1, 2', '{"type": "pause"', "{'type': 'pause'}", 'undefined', 'NaN', '\u0000',
    '{"type": pause}', '{"type": "set_target", "p": [0.5, 0.1, 0.4],}', '{"type":"set_target","p":[0.5,,0.4]}',
    '\ufeff\ufeff', 'true false', '{"type":"pause"}{"type":"pause"}', '{"type":"set_target","p":[01,0,0]}');
  for (let k = 0; k < 30; ++k) {
    let s = '';
    const n = 1 + Math.floor(rnd() * 200);
    for (let i = 0; i < n; ++i) s += String.fromCharCode(32 + Math.floor(rnd() * 95));
    m.push('{' + s);
  }
  // valid commands cut short: never JSON
  const whole = ['{"type":"set_target","p":[0.5,0.1,0.4]}', '{"type":"add_obstacle","shape":"box","p":[0.4,0,0.3]}',
    '{"type":"side_by_side","on":true}', '{"type":"controller","name":"rmpflow"}', '{"type":"speed","value":0.5}'];
  for (let k = 0; k < 80; ++k) {
    const w = whole[k % whole.length];
    m.push(w.slice(0, Math.floor(rnd() * (w.length - 1))));
  }
  // empty, and JSON that is not an object with a type
  m.push('', ' ', '\n', '{}', '[]', '"pause"', '123', 'true', 'null', '[{"type": "pause"}]');
  // deep nesting (below the size limit)
  m.push('['.repeat(5000) + ']'.repeat(5000), '{"a":'.repeat(1500) + '1' + '}'.repeat(1500),
    '{"type":"set_target","p":' + '['.repeat(3000) + ']'.repeat(3000) + '}',
    '{"type":"add_obstacle","shape":"box","p":[0.4,0,' + '['.repeat(2000) + '0' + ']'.repeat(2000) + ']}');
  // unknown types
  for (const t of ['fly', 'SET_TARGET', '', ' pause', 'pause ', 'hello', 'frame', 'error', 'set-target', 'x'.repeat(500)]) {
    m.push(JSON.stringify({ type: t }));
  }
  for (const t of [123, null, true, ['pause'], { type: 'pause' }, 1.5]) m.push(JSON.stringify({ type: t }));
  // missing fields
  m.push(...[
    { type: 'set_target' }, { type: 'set_obstacle', p: [0.4, 0, 0.3] }, { type: 'set_obstacle', id: 0 },
    { type: 'add_obstacle', p: [0.4, 0, 0.3] }, { type: 'add_obstacle', shape: 'box' }, { type: 'remove_obstacle' },
    { type: 'speed' }, { type: 'controller' }, { type: 'side_by_side' },
  ].map((x) => JSON.stringify(x)));
  // wrong types and shapes
  const badP = ['0.5,0.1,0.4', [0.5, 0.1], [0.5, 0.1, 0.4, 1], [], ['0.5', 0.1, 0.4], [null, 0.1, 0.4],
    [true, 0.1, 0.4], [{}, 0.1, 0.4], [[0.5], 0.1, 0.4], { x: 0.5, y: 0.1, z: 0.4 }, 0.5, null, false];
  for (const p of badP) {
    m.push(JSON.stringify({ type: 'set_target', p }), JSON.stringify({ type: 'add_obstacle', shape: 'box', p }),
      JSON.stringify({ type: 'set_obstacle', id: 0, p }));
  }
  for (const shape of ['cube', 'BOX', '', 1, null, ['box'], 'cylinder']) {
    m.push(JSON.stringify({ type: 'add_obstacle', shape, p: [0.4, 0, 0.3] }));
  }
  for (const id of ['0', 1.5, -0.5, true, null, [0], { id: 0 }]) {
    m.push(JSON.stringify({ type: 'set_obstacle', id, p: [0.4, 0, 0.3] }), JSON.stringify({ type: 'remove_obstacle', id }));
  }
  for (const value of ['1', null, true, [1], 0, 0.05, 1.5, -1, 100]) m.push(JSON.stringify({ type: 'speed', value }));
  for (const name of ['RMPflow', 'learnt', '', 5, null, ['rmpflow'], 'x'.repeat(1000)]) {
    m.push(JSON.stringify({ type: 'controller', name }));
  }
  for (const on of ['true', 1, 0, null, 'yes', [true]]) m.push(JSON.stringify({ type: 'side_by_side', on }));
  for (const seed of ['1', -1, 1.5, true, [1]]) m.push(JSON.stringify({ type: 'reset', seed }));
  // non-finite numbers (JSON has none: the parser must not turn them into inf or nan)
  for (const v of ['1e999', '-1e999', 'NaN', 'Infinity', '-Infinity', 'nan', '1e309']) {
    m.push(`{"type":"set_target","p":[${v},0.1,0.4]}`, `{"type":"set_obstacle","id":0,"p":[0.4,${v},0.3]}`,
      `{"type":"add_obstacle","shape":"sphere","p":[0.4,0,${v}]}`, `{"type":"speed","value":${v}}`);
  }
  // out of range
  for (const p of [[1e6, 0, 0.3], [0, 0, -5.01], [5.0001, 0, 0.3], [1e308, 1e308, 1e308], [-1e300, 0, 0], [0.4, -6, 0.3]]) {
    m.push(JSON.stringify({ type: 'set_target', p }), JSON.stringify({ type: 'add_obstacle', shape: 'box', p }),
      JSON.stringify({ type: 'set_obstacle', id: 0, p }));
  }
  for (const id of [16, 99, -1, 2 ** 31, 2 ** 53, 1e20, -1e20]) {
    m.push(`{"type":"set_obstacle","id":${id},"p":[0.4,0,0.3]}`, `{"type":"remove_obstacle","id":${id}}`);
  }
  m.push('{"type":"set_obstacle","id":18446744073709551616,"p":[0.4,0,0.3]}',
    '{"type":"remove_obstacle","id":-9223372036854775809}', '{"type":"seek","frame":0}', '{"type":"seek","frame":-1}');
  return m;
}

// The fuzz of step 4, run in a Web Worker of the page (its own thread: the page's rendering does not slow it down).
// Self-contained: its source is sent to the page. It answers {url, texts} with the statistics of what it sent.
function fuzzWorker() {
  self.onmessage = async (event) => {
    try {
      self.postMessage({ ok: true, stats: await run(event.data.url, event.data.texts) });
    } catch (e) {
      self.postMessage({ ok: false, error: String((e && e.stack) || e) });
    }
  };

  async function run(url, texts) {
    // the server's refused count, from the frames of a socket that stays open throughout
    let refused = null;
    const monitor = new WebSocket(url);
    monitor.onmessage = (e) => {
      const m = typeof e.data === 'string' && e.data.includes('"type":"frame"') && /"refused":(\d+)/.exec(e.data);
      if (m) refused = Number(m[1]);
    };
    const refusedNow = () => refused;
    const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
    const stats = { texts: texts.length, binary: 0, oversized: 0, burst: 0, textReplies: 0, binaryReplies: 0,
      burstReplies: 0, closedByServer: [], oversizedRefused: 0, oversizedClosed: 0, missing: [] };
    let replies = 0;
    const open = (label) => new Promise((resolve, reject) => {
      const s = new WebSocket(url);
      s.binaryType = 'arraybuffer';
      s.onmessage = (e) => {
        if (typeof e.data !== 'string' || !e.data.includes('"type":"error"')) return;
        try { if (JSON.parse(e.data).type === 'error') replies += 1; } catch (err) { /* not ours to judge */ }
      };
      s.onopen = () => { s.opened = true; resolve(s); };
      s.onerror = () => reject(new Error(`fuzz socket (${label}) failed to open`));
      s.onclose = () => { s.closed = true; if (s.opened && !s.closedByUs) stats.closedByServer.push(label); };
    });
    const close = (s, ...args) => { s.closedByUs = true; s.close(...args); };
    // waits until `n` error replies have come (true), or `ms` passed (false)
    const repliesReach = async (n, ms) => {
      const t0 = performance.now();
      while (replies < n) {
        if (performance.now() - t0 > ms) return false;
        await sleep(5);
      }
      return true;
    };

    const phase = {};
    let tPhase = performance.now();
    const endPhase = (name) => { const now = performance.now(); phase[name] = Math.round(now - tPhase); tPhase = now; };
    // every bad text, a few at a time (a page that floods is dropped: that is the burst's part), each answered
    for (let k = 0; refused === null; ++k) {
      if (k > 300) throw new Error('the monitor socket got no frames in 3 s');
      await sleep(10);
    }
    let s = await open('texts');
    for (let i = 0; i < texts.length && !s.closed; i += 8) {
      const chunk = texts.slice(i, i + 8);
      const base = replies;
      for (const m of chunk) s.send(m);
      if (!(await repliesReach(base + chunk.length, 1000))) {
        stats.missing.push(...texts.slice(i).map((m) => m.slice(0, 60)));  // this chunk and the rest: not waited for
        break;
      }
    }
    stats.textReplies = replies - stats.missing.length;
    stats.textSocketClosed = !!s.closed;
    close(s);
    endPhase('texts');

    // binary messages of random bytes, one at a time
    s = await open('binary');
    let seed = 7;
    const rnd = () => { seed = (seed * 1103515245 + 12345) & 0x7fffffff; return seed / 0x7fffffff; };
    replies = 0;
    let answered = true;  // once one goes unanswered, the rest are not waited for
    for (let k = 0; k < 12 && !s.closed; ++k) {
      const bytes = new Uint8Array(1 + Math.floor(rnd() * 300));
      for (let i = 0; i < bytes.length; ++i) bytes[i] = Math.floor(rnd() * 256);
      s.send(bytes.buffer);
      stats.binary += 1;
      if (answered) answered = await repliesReach(k + 1, 1000);
    }
    await sleep(200);
    stats.binaryReplies = replies;
    close(s);
    endPhase('binary');

    // messages over the size limit, each on its own socket: refused and counted (the server may close it)
    for (const m of [
      '{"type":"set_target","p":"' + 'x'.repeat(100 * 1024) + '"}',
      '{"type":"set_target","p":[0.5,0.1,0.4],"pad":"' + ' '.repeat(17 * 1024) + '"}',
      '"' + 'y'.repeat(100 * 1024) + '"',
    ]) {
      s = await open('oversized');
      const before = refusedNow();
      s.send(m);
      stats.oversized += 1;
      const t0 = performance.now();
      while (refusedNow() <= before && performance.now() - t0 < 2000) await sleep(10);
      if (refusedNow() > before) stats.oversizedRefused += 1;
      await sleep(50);
      if (s.closed) stats.oversizedClosed += 1; else close(s);
    }
    endPhase('oversized');

    // a burst of valid add_obstacle far from the arm: at most max_obstacles are kept, the rest are refused, and
    // the server may drop the flooding socket
    s = await open('burst');
    replies = 0;
    const refusedBeforeBurst = refusedNow();
    for (let k = 0; k < 2000; ++k) {
      s.send(JSON.stringify({ type: 'add_obstacle', shape: k % 2 ? 'box' : 'sphere', p: [-2, -2 + 0.002 * k, 0.2] }));
      stats.burst += 1;
    }
    for (let quiet = 0, last = -1; quiet < 300 && !s.closed; quiet = replies === last ? quiet + 20 : 0) {
      last = replies;
      await sleep(20);
    }
    await sleep(100);  // a frame with the new count
    stats.burstReplies = replies;
    stats.burstRefused = refusedNow() - refusedBeforeBurst;
    stats.burstSocketClosed = !!s.closed;
    if (!s.closed) close(s);
    endPhase('burst');

    // sockets that go away during the handshake, right after opening, and right after sending half a message
    for (let k = 0; k < 4; ++k) { const t = new WebSocket(url); t.onerror = () => {}; t.close(); }
    for (let k = 0; k < 4; ++k) close(await open('abrupt'));
    for (let k = 0; k < 4; ++k) { const t = await open('abrupt'); t.send('{"type":'); close(t, 4000, 'bye'); }
    await sleep(300);
    endPhase('abrupt');
    stats.phaseMs = phase;
    monitor.close();
    return stats;
  }
}

// ---------------------------------------------------------------- the test

async function main() {
  const started = Date.now();
  const opts = parseArgs(process.argv.slice(2));
  fs.mkdirSync(opts.out, { recursive: true });
  const require = createRequire(path.join(WEB, 'package.json'));
  let chromium;
  try {
    ({ chromium } = require('playwright-core'));
  } catch (e) {
    throw new Failure(`cannot load playwright-core from ${WEB}/node_modules (run npm ci in web/): ${e.message}`);
  }

  const webRoot = opts['web-root'] ? ['--web-root', path.resolve(opts['web-root'])] : [];
  const server = startServer(path.resolve(opts.rmpmarl), webRoot, path.join(opts.out, 'server.log'));
  let replayServer = null, restarted = null, sceneServer = null, sceneDir = null, context = null;
  const userDataDir = fs.mkdtempSync(path.join(os.tmpdir(), 'rmpmarl-viewer-test-'));
  const watchdog = setTimeout(async () => {
    console.log(`FAIL the test did not finish within ${TOTAL_TIMEOUT_MS / 1000} s (in step '${currentStep}')`);
    server.proc.kill('SIGKILL');
    for (const x of [replayServer, restarted, sceneServer]) if (x) x.proc.kill('SIGKILL');
    process.exit(1);
  }, TOTAL_TIMEOUT_MS);
  watchdog.unref();

  const consoleLog = fs.createWriteStream(path.join(opts.out, 'console.log'));
  const pageErrors = [];
  try {
    const url = await server.url;
    console.log(`server: ${url} (after ${((Date.now() - started) / 1000).toFixed(1)} s)`);
    const port = Number(new URL(url).port);

    context = await chromium.launchPersistentContext(userDataDir, {
      executablePath: CHROMIUM, headless: true, args: CHROMIUM_ARGS, viewport: VIEWPORT, acceptDownloads: true,
    });
    const page = context.pages()[0] ?? await context.newPage();
    page.on('console', (msg) => consoleLog.write(`${msg.type()}: ${msg.text()}\n`));
    page.on('pageerror', (e) => { pageErrors.push(e.message); consoleLog.write(`pageerror: ${e.stack}\n`); });

    // ---- 1
    let scenarioObstacles = 0;
    await step('1 page loads, hello and frames arrive, the arm is drawn', async () => {
      const response = await page.goto(url);
      check(response && response.status() === 200, `GET / answered ${response && response.status()}`);
      await waitInPage(page, () => window.__rmpmarlViewer && window.__rmpmarlViewer.hello
        && window.__rmpmarlViewer.frames >= 10, null, 10_000, 'hello and 10 frames');
      const webgl = await page.evaluate(() => {
        const gl = document.createElement('canvas').getContext('webgl2');
        const info = gl && gl.getExtension('WEBGL_debug_renderer_info');
        return info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : String(gl);
      });
      const f0 = await page.evaluate(() => window.__rmpmarlViewer.frames);
      await sleep(2000);
      const s = await page.evaluate(({ tol }) => {
        const v = window.__rmpmarlViewer, h = v.hello, f = v.frame;
        const canvas = document.getElementById('scene');
        return {
          frames: v.frames, version: h.version, mode: h.mode, links: h.robot.links.length,
          capsules: h.robot.capsules.length, frameLinks: f.arms[0].links.length, arms: f.arms.length,
          armPixels: v.countPixels(v.armColor, tol), armColor: v.armColor,
          totalPixels: canvas.width * canvas.height, seekVisible: !!document.getElementById('seek').offsetParent,
          disconnected: !document.getElementById('banner').hidden, obstacles: f.obstacles.length,
        };
      }, { tol: ARM_COLOR_TOL });
      await page.screenshot({ path: path.join(opts.out, 'viewer.png') });
      scenarioObstacles = s.obstacles;
      const rate = (s.frames - f0) / 2;
      check(s.version === 1, `hello.version ${s.version}, expected 1`);
      check(s.mode === 'live', `hello.mode ${s.mode}, expected live`);
      check(s.capsules > 0, 'hello.robot.capsules is empty');
      check(s.frameLinks === s.links, `frame has ${s.frameLinks} link poses, hello.robot.links has ${s.links}`);
      check(rate >= 10, `${rate} frames/s received, expected about 30`);
      check(!s.disconnected, 'the page shows "disconnected"');
      check(!s.seekVisible, '#seek is visible in live mode');
      check(s.armPixels > MIN_ARM_PIXELS, `${s.armPixels} pixels of the arm colour [${s.armColor}] (±${ARM_COLOR_TOL}), `
        + `expected > ${MIN_ARM_PIXELS}: the arm is not drawn (WebGL: ${webgl})`);
      check(s.armPixels < 0.5 * s.totalPixels, `${s.armPixels} of ${s.totalPixels} pixels have the arm colour`);
      return `${rate.toFixed(1)} frames/s, ${s.links} links, ${s.capsules} capsules, arm pixels ${s.armPixels}`
        + ` of ${s.totalPixels}; WebGL: ${webgl}`;
    }, { fatal: true });

    // ---- 2
    let heldTarget = null;
    await step('2 dragging the target steers the arm', async () => {
      // The scenario's four cubes cross the workspace; one passing the target pushes either controller off it for
      // seconds, which is right and beside the point of steps 2 and 3a (the page steers the arm). So they are held far
      // from the arm first; the reset of step 4b lets them follow the scenario again.
      const parked = await page.evaluate(() => {
        const v = window.__rmpmarlViewer;
        const ids = v.frame.obstacles.map((o) => o.id);
        ids.forEach((id, k) => v.send({ type: 'set_obstacle', id, p: [-1.5, -1.5 + 0.2 * k, 0.2] }));
        return ids.length;
      });
      await waitInPage(page, ({ n }) => {
        const obstacles = window.__rmpmarlViewer.frame.obstacles;
        return obstacles.length === n && obstacles.every((o) => o.held && o.p[0] < -1.4);
      }, { n: parked }, 3000, `the ${parked} scenario obstacles held far from the arm`);
      // a destination inside the workspace, DRAG_DISTANCE from the target, moving far on screen
      const plan = await page.evaluate(({ dd }) => {
        const v = window.__rmpmarlViewer, ws = v.hello.workspace, p0 = v.frame.target.p;
        const s0 = v.project(p0);
        // the line of sight through p0: the direction in which the screen position does not change (the null space of
        // the projection's Jacobian); a drag moves the target across it
        const eps = 1e-3;
        const J = [0, 1, 2].map((i) => {
          const q = p0.slice();
          q[i] += eps;
          const s = v.project(q);
          return [(s.x - s0.x) / eps, (s.y - s0.y) / eps];
        });
        const ray = [J[1][0] * J[2][1] - J[2][0] * J[1][1], J[2][0] * J[0][1] - J[0][0] * J[2][1],
          J[0][0] * J[1][1] - J[1][0] * J[0][1]];
        const rn = Math.hypot(...ray);
        const margin = 0.03, dirs = [];
        for (const dx of [-1, 0, 1]) for (const dy of [-1, 0, 1]) for (const dz of [-1, 0, 1]) {
          const along = (dx * ray[0] + dy * ray[1] + dz * ray[2]) / rn;
          const d = [dx - (along * ray[0]) / rn, dy - (along * ray[1]) / rn, dz - (along * ray[2]) / rn];
          const n = Math.hypot(...d);
          if (n > 0.3) dirs.push(d.map((x) => x / n));
        }
        const candidates = [];
        for (const d of dirs) {
          const p = p0.map((x, i) => x + dd * d[i]);
          if (p.some((x, i) => x < ws.min[i] + margin || x > ws.max[i] - margin)) continue;
          const s = v.project(p);
          const clear = Math.min(Infinity, ...v.frame.obstacles.map((o) => Math.hypot(...o.p.map((x, i) => x - p[i]))));
          candidates.push({ p, screen: Math.hypot(s.x - s0.x, s.y - s0.y), clear });
        }
        // well visible on screen, and as far from the obstacles as such a point can be
        const most = Math.max(...candidates.map((c) => c.screen));
        const best = candidates.filter((c) => c.screen >= 0.6 * most).sort((a, b) => b.clear - a.clear)[0];
        return { p0, dest: best && best.p, screen: best && best.screen, held: v.frame.target.held };
      }, { dd: DRAG_DISTANCE });
      check(plan.dest, `no point ${DRAG_DISTANCE} m from the target ${vec(plan.p0)} inside the workspace`);
      // grab the target where it is now (it may be moving), drag in 10 steps, release
      const start = await page.evaluate(() => window.__rmpmarlViewer.project(window.__rmpmarlViewer.frame.target.p));
      const end = await page.evaluate((p) => window.__rmpmarlViewer.project(p), plan.dest);
      await page.mouse.move(start.x, start.y);
      await page.mouse.down();
      for (let k = 1; k <= 10; ++k) {
        await page.mouse.move(start.x + ((end.x - start.x) * k) / 10, start.y + ((end.y - start.y) * k) / 10);
        await sleep(35);
      }
      await page.mouse.up();
      const released = Date.now();
      // the target the server now holds
      const held = await waitInPage(page, () => {
        const f = window.__rmpmarlViewer.frame;
        return f.target.held && f.target.p;
      }, null, 1000, 'a frame with the target held after the drag');
      await sleep(150);  // the release's own set_target
      const last = await page.evaluate(() => ({
        held: window.__rmpmarlViewer.frame.target.p, sent: window.__rmpmarlViewer.lastDrag }));
      heldTarget = last.held;
      check(last.sent && last.sent.type === 'set_target', `the page's last drag message is ${JSON.stringify(last.sent)}`);
      check(dist(heldTarget, last.sent.p) < 1e-3, `the server holds the target at ${vec(heldTarget)}, the page's last`
        + ` set_target said ${vec(last.sent.p)}`);
      const moved = dist(heldTarget, plan.p0), offDest = dist(heldTarget, plan.dest);
      check(moved > 0.5 * DRAG_DISTANCE, `the held target ${vec(heldTarget)} is ${fmt(moved)} m from where it was `
        + `${vec(plan.p0)}: the drag did not move it (screen ${fmt(plan.screen, 0)} px)`);
      check(offDest < 0.05, `the held target ${vec(heldTarget)} is ${fmt(offDest)} m from the drag's destination `
        + `${vec(plan.dest)}`);
      const tracked = await waitInPage(page, ({ p, tol }) => {
        const f = window.__rmpmarlViewer.frame, e = f.arms[0].ee;
        const d = Math.hypot(e[0] - p[0], e[1] - p[1], e[2] - p[2]);
        return f.target.held && d < tol && d;
      }, { p: heldTarget, tol: TRACK_TOL }, TRACK_TIME_MS + 1000, `end effector within ${TRACK_TOL} m of the target`)
        .catch(async (e) => {
          const f = await page.evaluate(() => window.__rmpmarlViewer.frame);
          throw new Failure(`${e.message}; at the end ee ${vec(f.arms[0].ee)}, target ${vec(f.target.p)} `
            + `(held ${f.target.held}), error ${fmt(dist(f.arms[0].ee, f.target.p))} m`);
        });
      const ms = Date.now() - released;
      check(ms <= TRACK_TIME_MS, `the end effector reached the target ${ms} ms after the release, expected <= ${TRACK_TIME_MS}`);
      return `dragged ${vec(plan.p0)} → held ${vec(heldTarget)} (${fmt(moved)} m; destination ${vec(plan.dest)}),`
        + ` held after ${held.ms} ms; ee within ${TRACK_TOL * 1000} mm (${fmt(tracked.value * 1000, 1)} mm)`
        + ` ${ms} ms after the release (the scenario's ${parked} obstacles held away)`;
    });

    // ---- 3
    await step('3a controller switch to RMPflow', async () => {
      const controllers = await page.evaluate(() => window.__rmpmarlViewer.hello.controllers);
      check(controllers.includes('rmpflow'), `hello.controllers ${JSON.stringify(controllers)} lacks rmpflow`);
      const t0 = Date.now();
      await page.selectOption('#controller', 'rmpflow');
      await waitInPage(page, () => {
        const v = window.__rmpmarlViewer, h = v.hello, f = v.frame;
        return h.controller === 'rmpflow' && h.arms.length === 1 && h.arms[0].controller === 'rmpflow'
          && f.arms.length === 1 && f.arms[0].joints === null;
      }, null, 3000, 'a hello with controller rmpflow and frames with joints null');
      const s = await page.evaluate(() => ({
        held: window.__rmpmarlViewer.frame.target.held, p: window.__rmpmarlViewer.frame.target.p,
        panel: document.getElementById('joints').textContent,
      }));
      check(/RMPflow has no agents/.test(s.panel), 'the joint panel does not say that RMPflow has no agents');
      check(s.held, 'the target is no longer held after the controller switch');
      const tracked = await waitInPage(page, ({ tol }) => {
        const f = window.__rmpmarlViewer.frame, e = f.arms[0].ee, p = f.target.p;
        const d = Math.hypot(e[0] - p[0], e[1] - p[1], e[2] - p[2]);
        return f.target.held && d < tol && d;
      }, { tol: TRACK_TOL }, TRACK_TIME_MS, `RMPflow's end effector within ${TRACK_TOL} m of the held target`)
        .catch(async (e) => {
          const f = await page.evaluate(() => window.__rmpmarlViewer.frame);
          throw new Failure(`${e.message}; at the end ee ${vec(f.arms[0].ee)}, target ${vec(f.target.p)} `
            + `(held ${f.target.held}), error ${fmt(dist(f.arms[0].ee, f.target.p))} m, obstacles `
            + `${f.obstacles.map((o) => vec(o.p)).join(' ')}`);
        });
      return `switched in ${Date.now() - t0 - tracked.ms} ms; tracks the held target ${vec(s.p)} to `
        + `${fmt(tracked.value * 1000, 1)} mm after ${tracked.ms} ms`;
    });

    await step('3b side by side on and off, back to the learned controller', async () => {
      await page.check('#side-by-side');
      const on = await waitInPage(page, () => {
        const v = window.__rmpmarlViewer, h = v.hello, f = v.frame;
        return h.side_by_side === true && h.arms.length === 2 && f.arms.length === 2
          && { labels: h.arms.map((a) => `${a.label} (${a.controller})`), joints: f.arms.map((a) => a.joints !== null) };
      }, null, 3000, 'a hello and frames with 2 arms');
      check(on.value.joints[0] && !on.value.joints[1], `side by side: joints given for arms ${JSON.stringify(on.value.joints)}`
        + ', expected the learned controller (joints) on the first and RMPflow (null) on the second');
      await sleep(500);
      await page.screenshot({ path: path.join(opts.out, 'viewer-side-by-side.png') });
      await page.uncheck('#side-by-side');
      const off = await waitInPage(page, () => {
        const v = window.__rmpmarlViewer;
        return v.hello.side_by_side === false && v.hello.arms.length === 1 && v.frame.arms.length === 1;
      }, null, 3000, 'a hello and frames with 1 arm again');
      await page.selectOption('#controller', 'learned');
      const back = await waitInPage(page, () => {
        const v = window.__rmpmarlViewer;
        return v.hello.controller === 'learned' && v.frame.arms.length === 1 && Array.isArray(v.frame.arms[0].joints);
      }, null, 3000, 'a hello with controller learned and frames with joints');
      return `2 arms after ${on.ms} ms (${on.value.labels.join(', ')}), 1 arm again after ${off.ms} ms, `
        + `back to the learned controller after ${back.ms} ms`;
    });

    // ---- 4
    await step('4 bad messages are refused; the simulation and the page go on', async () => {
      const before = await page.evaluate(() => ({
        frames: window.__rmpmarlViewer.frames, refused: window.__rmpmarlViewer.frame.refused,
        t: window.__rmpmarlViewer.frame.t,
      }));
      const texts = badTextMessages();
      const fuzz = await page.evaluate(async ({ src, texts }) => {
        const worker = new Worker(URL.createObjectURL(new Blob([`(${src})()`], { type: 'text/javascript' })));
        return new Promise((resolve, reject) => {
          worker.onmessage = (e) => {
            worker.terminate();
            if (e.data.ok) resolve(e.data.stats); else reject(new Error(`fuzz worker: ${e.data.error}`));
          };
          worker.onerror = (e) => reject(new Error(`fuzz worker: ${e.message}`));
          worker.postMessage({ url: `ws://${location.host}/ws`, texts });
        });
      }, { src: fuzzWorker.toString(), texts });
      // raw TCP from here: half a handshake, a handshake and half a frame, garbage, then cut the connection
      const key = Buffer.from('0123456789abcdef').toString('base64');
      const upgrade = `GET /ws HTTP/1.1\r\nHost: 127.0.0.1:${port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n`
        + `Sec-WebSocket-Key: ${key}\r\nSec-WebSocket-Version: 13\r\n\r\n`;
      await Promise.all([
        abruptSocket(port, 'GET /ws HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgr', 100),
        abruptSocket(port, upgrade, 100),
        abruptSocket(port, Buffer.concat([Buffer.from(upgrade), Buffer.from([0x81, 0xfe, 0x40])]), 200),
        abruptSocket(port, Buffer.concat([Buffer.from(upgrade), Buffer.from([0x81, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff])]), 200),
        abruptSocket(port, Buffer.from(Array.from({ length: 4096 }, (_, i) => (i * 37) & 0xff)), 100),
        abruptSocket(port, null, 50),
      ]);
      await sleep(1000);
      const after = await page.evaluate(() => ({
        frames: window.__rmpmarlViewer.frames, refused: window.__rmpmarlViewer.frame.refused,
        t: window.__rmpmarlViewer.frame.t, paused: window.__rmpmarlViewer.frame.paused,
        connected: window.__rmpmarlViewer.connected, obstacles: window.__rmpmarlViewer.frame.obstacles.length,
        max: window.__rmpmarlViewer.hello.limits.max_obstacles,
      }));
      await sleep(1000);
      const later = await page.evaluate(() => ({ frames: window.__rmpmarlViewer.frames, t: window.__rmpmarlViewer.frame.t }));
      const home = await httpGet(port, '/');
      const traversal = await Promise.all(['/../CMakeLists.txt', '/..%2fCMakeLists.txt', '/%2e%2e/%2e%2e/etc/passwd',
        '/../../../../../../etc/passwd', '//etc/passwd', '/web/index.html/../../CMakeLists.txt']
        .map((p) => httpGet(port, p).then((r) => ({ p, ...r }))));

      const refused = after.refused - before.refused;
      const totalBad = fuzz.texts + fuzz.burst + fuzz.binary + fuzz.oversized;
      const details = `sent ${fuzz.texts} bad texts (${fuzz.textReplies} error replies), ${fuzz.binary} binary `
        + `(${fuzz.binaryReplies} replies), ${fuzz.oversized} oversized (${fuzz.oversizedRefused} counted, `
        + `${fuzz.oversizedClosed} sockets closed), ${fuzz.burst} add_obstacle in a burst (${fuzz.burstRefused} refused,`
        + ` ${fuzz.burstReplies} replies, socket ${fuzz.burstSocketClosed ? 'dropped' : 'kept'}): ${totalBad} in all; `
        + `refused +${refused}; `
        + `obstacles now ${after.obstacles}/${after.max}; frames +${later.frames - after.frames} and `
        + `t +${fmt(later.t - after.t, 2)} s in the last second; phases [ms] ${JSON.stringify(fuzz.phaseMs)}`;
      check(fuzz.texts + fuzz.binary + fuzz.oversized >= 300, `only ${fuzz.texts} bad messages; ${details}`);
      check(!fuzz.textSocketClosed, `the server closed the socket of the bad texts (sent 8 at a time); ${details}`);
      check(fuzz.missing.length === 0, `no error reply to ${fuzz.missing.length} bad texts, e.g. `
        + `${JSON.stringify(fuzz.missing.slice(0, 3))}; ${details}`);
      check(fuzz.binaryReplies === fuzz.binary, `${fuzz.binaryReplies} error replies to ${fuzz.binary} binary messages;`
        + ` ${details}`);
      check(fuzz.oversizedRefused === fuzz.oversized, `${fuzz.oversized - fuzz.oversizedRefused} oversized messages`
        + ` were not counted as refused; ${details}`);
      check(fuzz.burstRefused > 0, `no add_obstacle of the burst beyond max_obstacles was refused; ${details}`);
      check(refused >= fuzz.texts + fuzz.binary + fuzz.oversized + fuzz.burstRefused, `refused increased by ${refused},`
        + ` fewer than the bad texts, binary and oversized messages and the refused add_obstacle; ${details}`);
      check(after.obstacles <= after.max, `${after.obstacles} obstacles, more than max_obstacles ${after.max}`);
      check(after.connected, `the page lost its connection; ${details}`);
      check(later.frames - after.frames >= 10, `the page received ${later.frames - after.frames} frames in 1 s after `
        + `the fuzz; ${details}`);
      check(!after.paused && later.t - after.t > 0.5, `the simulation time went ${fmt(after.t)} → ${fmt(later.t)} s in`
        + ` 1 s after the fuzz; ${details}`);
      check(home.status === 200 && /<html/i.test(home.body), `GET / answered ${home.status} after the fuzz`);
      for (const r of traversal) {
        check(!/cmake_minimum_required|root:x:0/.test(r.body), `GET ${r.p} served a file outside the page`);
      }
      check(pageErrors.length === 0, `the page threw: ${pageErrors.join(' | ')}`);
      // the page's own socket got no refusals: the fuzz ran on its own sockets
      return details;
    });
    await step('4b reset: a new episode of the scenario; rtf stays plausible', async () => {
      const before = await page.evaluate(() => window.__rmpmarlViewer.frame.t);
      await page.click('#reset');
      const samples = [];
      const t0 = Date.now();
      while (Date.now() - t0 < 2300) {  // the server's statistics window is 1 s: two windows after the reset
        samples.push(await page.evaluate(() => {
          const f = window.__rmpmarlViewer.frame;
          return { t: f.t, rtf: f.rtf, obstacles: f.obstacles.length, held: f.target.held };
        }));
        await sleep(50);
      }
      const last = samples[samples.length - 1];
      const rtfs = samples.map((x) => x.rtf);
      const details = `t ${fmt(before, 2)} → ${fmt(samples[0].t, 2)} … ${fmt(last.t, 2)} s; obstacles ${last.obstacles}`
        + ` (the scenario's: ${scenarioObstacles}); rtf over 2.3 s in [${fmt(Math.min(...rtfs), 2)}, `
        + `${fmt(Math.max(...rtfs), 2)}]`;
      check(samples.some((x) => x.t < before), `the simulation time did not start over; ${details}`);
      check(last.obstacles === scenarioObstacles, `after the reset ${last.obstacles} obstacles, expected the scenario's`
        + ` ${scenarioObstacles}; ${details}`);
      check(!last.held, `the target is still held after the reset; ${details}`);
      check(rtfs.every((x) => x >= 0 && x < 3), `rtf left [0, 3) after the reset; ${details}`);
      return details;
    });

    // ---- 5
    let replayFile = null;
    await step('5 measurement: page fps, rtf and load over 5 s (and a recording)', async () => {
      const downloadPromise = page.waitForEvent('download', { timeout: 15_000 });
      await page.click('#record');
      const samples = [];
      const f0 = await page.evaluate(() => window.__rmpmarlViewer.frames);
      const t0 = Date.now();
      let lastSeq = -1;
      while (Date.now() - t0 < 5000) {
        await sleep(250);
        const s = await page.evaluate(() => {
          const v = window.__rmpmarlViewer;
          return { fps: v.fps, draws: v.drawFps, rtf: v.frame.rtf, load: v.frame.load, seq: v.frame.seq, t: v.frame.t, arms: v.frame.arms.map((a) => a.step_us) };
        });
        if (s.seq !== lastSeq) samples.push(s);
        lastSeq = s.seq;
      }
      const frames = (await page.evaluate(() => window.__rmpmarlViewer.frames)) - f0;
      await page.click('#record');
      const download = await downloadPromise;
      replayFile = path.join(opts.out, 'replay.json');
      await download.saveAs(replayFile);
      const stat = (k) => {
        const xs = samples.map((s) => s[k]).filter(Number.isFinite);
        return { mean: xs.reduce((a, b) => a + b, 0) / Math.max(1, xs.length), min: Math.min(...xs), max: Math.max(...xs) };
      };
      const fps = stat('fps'), draws = stat('draws'), rtf = stat('rtf'), load = stat('load');
      const simSpan = samples.length > 1 ? samples[samples.length - 1].t - samples[0].t : 0;
      const stepUs = samples.flatMap((s) => s.arms).filter(Number.isFinite);
      const replay = JSON.parse(fs.readFileSync(replayFile, 'utf8'));
      const details = `page draws/s mean ${fmt(draws.mean, 1)} (min ${draws.min}, max ${draws.max}), animation `
        + `frames/s ${fmt(fps.mean, 1)} (min ${fps.min}, max ${fps.max}); frames received `
        + `${fmt(frames / 5, 1)}/s; rtf mean ${fmt(rtf.mean, 2)} (min ${fmt(rtf.min, 2)}, max ${fmt(rtf.max, 2)}); `
        + `load mean ${fmt(100 * load.mean, 1)}% (max ${fmt(100 * load.max, 1)}%); control step mean `
        + `${fmt(stepUs.reduce((a, b) => a + b, 0) / Math.max(1, stepUs.length), 1)} µs; sim time +${fmt(simSpan, 2)} s`
        + ` over ${fmt((Date.now() - t0) / 1000, 1)} s wall; replay ${replay.frames && replay.frames.length} frames`;
      // the drawing rate the browser sustains: the scene drawn at every animation frame for 3 s, the simulation
      // keeping its clock meanwhile
      await page.evaluate(() => { window.__rmpmarlViewer.continuous = true; });
      await sleep(1200);
      const drawing = [];
      for (let k = 0; k < 8; ++k) {
        await sleep(250);
        drawing.push(await page.evaluate(() => ({ draws: window.__rmpmarlViewer.drawFps,
          rtf: window.__rmpmarlViewer.frame.rtf })));
      }
      await page.evaluate(() => { window.__rmpmarlViewer.continuous = false; });
      const mean = (xs) => xs.reduce((a, b) => a + b, 0) / Math.max(1, xs.length);
      const continuous = `; drawing at every animation frame: ${fmt(mean(drawing.map((d) => d.draws)), 1)} draws/s `
        + `(min ${Math.min(...drawing.map((d) => d.draws))}), rtf ${fmt(mean(drawing.map((d) => d.rtf)), 2)} `
        + `(min ${fmt(Math.min(...drawing.map((d) => d.rtf)), 2)})`;
      check(samples.length >= 5, `only ${samples.length} distinct frames sampled in 5 s; ${details}`);
      check(draws.mean >= 2, `the page draws ${fmt(draws.mean, 1)} times per second; ${details}`);
      check(frames >= 50, `${frames} frames received in 5 s; ${details}`);
      check(rtf.mean > 0.3 && rtf.max < 3, `rtf ${fmt(rtf.mean, 2)} is not plausible; ${details}`);
      check(load.min >= 0 && load.max <= 1.5, `load outside [0, 1.5]; ${details}`);
      check(replay.format === 'rmpmarl-replay' && replay.version === 1 && replay.hello && replay.hello.type === 'hello',
        `the recording is not a replay file: ${JSON.stringify(Object.keys(replay))}`);
      check(Array.isArray(replay.frames) && replay.frames.length >= 50 && replay.frames.every((f) => f.type === 'frame'),
        `the recording holds ${replay.frames && replay.frames.length} frames, expected >= 50`);
      check(replay.frames.every((f, i) => i === 0 || f.t > replay.frames[i - 1].t), 'the recording\'s times do not increase');
      return details + continuous;
    });

    // ---- 6
    if (replayFile) {
      await step('6 the recording plays back in `rmpmarl view --replay`', async () => {
        replayServer = startServer(path.resolve(opts.rmpmarl), [...webRoot, '--replay', replayFile],
          path.join(opts.out, 'server-replay.log'));
        const replayUrl = await replayServer.url;
        const p2 = await context.newPage();
        p2.on('pageerror', (e) => pageErrors.push(e.message));
        await p2.goto(replayUrl);
        const h = await waitInPage(p2, () => {
          const v = window.__rmpmarlViewer;
          return v && v.hello && v.frames >= 5 && v.hello;
        }, null, 10_000, 'a hello and frames from the replay server');
        const n = JSON.parse(fs.readFileSync(replayFile, 'utf8')).frames.length;
        check(h.value.mode === 'replay', `hello.mode ${h.value.mode}, expected replay`);
        check(h.value.replay && h.value.replay.frames === n, `hello.replay ${JSON.stringify(h.value.replay)}, expected ${n} frames`);
        check(await p2.isVisible('#seek'), '#seek is not visible in replay mode');
        await p2.click('#pause');
        await waitInPage(p2, () => window.__rmpmarlViewer.frame.paused, null, 2000, 'a paused frame');
        const target = Math.floor(n / 2);
        await p2.evaluate((k) => {
          const s = document.getElementById('seek');
          s.value = String(k);
          s.dispatchEvent(new Event('change'));
        }, target);
        const seeked = await waitInPage(p2, (k) => {
          const f = window.__rmpmarlViewer.frame;
          return f.index === k && f;
        }, target, 2000, `frame ${target} after seeking`);
        await p2.screenshot({ path: path.join(opts.out, 'viewer-replay.png') });
        await p2.close();
        return `${n} frames, paused and sought to frame ${target} (t ${fmt(seeked.value.t, 2)} s)`;
      });
    }

    // ---- 7
    await step('7 the page shows "disconnected" when the server goes, and reconnects when it is back', async () => {
      await stopServer(server);
      exits.length = 0;  // that one was asked to stop
      const gone = await waitInPage(page, () => !window.__rmpmarlViewer.connected
        && !document.getElementById('banner').hidden && document.getElementById('banner').textContent, null, 3000,
      'the "disconnected" banner after the server stopped');
      check(/disconnected/.test(gone.value), `the banner says ${JSON.stringify(gone.value)}`);
      const frames = await page.evaluate(() => window.__rmpmarlViewer.frames);
      const t0 = Date.now();
      restarted = startServer(path.resolve(opts.rmpmarl), webRoot, path.join(opts.out, 'server-restarted.log'), port);
      await restarted.url;
      const back = await waitInPage(page, (n) => window.__rmpmarlViewer.connected
        && document.getElementById('banner').hidden && window.__rmpmarlViewer.frames > n + 5, frames, 5000,
      'frames again after the server restarted');
      return `"disconnected" after ${gone.ms} ms; frames again ${Date.now() - t0} ms after the restart `
        + `(${back.ms} ms after its URL was printed)`;
    });

    // ---- 8
    await step('8 a MoveIt planning scene (`--scene`): its cylinder and box drawn with their sizes and poses', async () => {
      sceneDir = fs.mkdtempSync(path.join(os.tmpdir(), 'rmpmarl-viewer-scene-'));
      const sceneFile = path.join(sceneDir, 'scene.yaml');
      fs.writeFileSync(sceneFile, SCENE_YAML);
      sceneServer = startServer(path.resolve(opts.rmpmarl), [...webRoot, '--robot', 'panda', '--policy', 'rmpflow',
        '--scene', sceneFile, '--duration', '60'], path.join(opts.out, 'server-scene.log'));
      const sceneUrl = await sceneServer.url;
      const p3 = await context.newPage();
      p3.on('pageerror', (e) => pageErrors.push(e.message));
      await p3.goto(sceneUrl);
      const got = await waitInPage(p3, () => {
        const v = window.__rmpmarlViewer;
        if (!v || !v.hello || v.frames < 5) return null;
        const meshes = v.obstacleMeshes();
        return meshes.length === v.frame.obstacles.length && meshes.length > 0
          && { obstacles: v.frame.obstacles, meshes };
      }, null, 10_000, 'frames from the scene server and a mesh for each of their obstacles');
      await p3.screenshot({ path: path.join(opts.out, 'viewer-scene.png') });
      await p3.close();
      const { obstacles, meshes } = got.value;
      const near = (a, b, tol) => a.length === b.length && a.every((x, i) => Math.abs(x - b[i]) <= tol);
      // v rotated by the quaternion [x, y, z, w]
      const rotate = ([x, y, z, w], v) => {
        const t = [2 * (y * v[2] - z * v[1]), 2 * (z * v[0] - x * v[2]), 2 * (x * v[1] - y * v[0])];
        return [v[0] + w * t[0] + y * t[2] - z * t[1], v[1] + w * t[1] + z * t[0] - x * t[2],
          v[2] + w * t[2] + x * t[1] - y * t[0]];
      };
      const shapes = `frame obstacles ${JSON.stringify(obstacles.map((o) => ({ shape: o.shape, size: o.size, p: o.p, q: o.q })))}`
        + `; meshes ${JSON.stringify(meshes.map((m) => ({ type: m.type, extent: m.extent.map((x) => +fmt(x, 4)),
          p: m.p.map((x) => +fmt(x, 4)), q: m.q.map((x) => +fmt(x, 4)) })))}`;
      check(obstacles.length === 2, `${obstacles.length} obstacles, expected the scene's 2 (a cylinder and a box); ${shapes}`);
      // the protocol: a cylinder's size is [radius, half length], its q [w, x, y, z] turns its z axis
      const can = obstacles.find((o) => o.shape === 'cylinder');
      check(can, `no obstacle with shape cylinder; ${shapes}`);
      check(near(can.size, [0.05, 0.15], SIZE_TOL), `the cylinder's size ${JSON.stringify(can.size)}, expected `
        + `[0.05, 0.15] (radius, half length); ${shapes}`);
      check(Array.isArray(can.q) && can.q.length === 4, `the cylinder has no quaternion: ${JSON.stringify(can.q)}`);
      // the page: a CylinderGeometry r 0.05, h 0.3 whose axis (the mesh's z: obstacleGeometry turns three.js's y
      // axis onto z) lies along world −y, centred where the scene put it
      const cyl = meshes.find((m) => m.type === 'CylinderGeometry');
      check(cyl, `no mesh with a CylinderGeometry; ${shapes}`);
      const c = cyl.parameters;
      check(Math.abs(c.radiusTop - 0.05) <= SIZE_TOL && Math.abs(c.radiusBottom - 0.05) <= SIZE_TOL
        && Math.abs(c.height - 0.3) <= SIZE_TOL, `the CylinderGeometry has radii ${c.radiusTop}, ${c.radiusBottom} and `
        + `height ${c.height}, expected 0.05 and 0.3`);
      check(near(cyl.extent, [0.1, 0.1, 0.3], SIZE_TOL), `the cylinder's mesh spans ${vec(cyl.extent)} in its own `
        + 'frame, expected [0.1, 0.1, 0.3]: its axis is not the mesh\'s z');
      const axis = rotate(cyl.q, [0, 0, 1]);
      check(near(axis, [0, -1, 0], POSE_TOL), `the cylinder's axis in the world is ${vec(axis)}, expected [0, -1, 0]`
        + ` (mesh quaternion [x, y, z, w] ${vec(cyl.q)}; frame q [w, x, y, z] ${vec(can.q)})`);
      check(near(cyl.p, [0.5, 0.2, 0.3], POSE_TOL), `the cylinder's mesh is at ${vec(cyl.p)}, expected [0.5, 0.2, 0.3]`);
      // the box: BoxGeometry of the full sides (the frame's size: half sides), where the scene put it
      const box = meshes.find((m) => m.type === 'BoxGeometry');
      check(box, `no mesh with a BoxGeometry; ${shapes}`);
      const b = box.parameters;
      check(near([b.width, b.height, b.depth], [0.2, 0.1, 0.02], SIZE_TOL), `the BoxGeometry is ${b.width} × `
        + `${b.height} × ${b.depth}, expected 0.2 × 0.1 × 0.02`);
      check(near(box.p, [0.5, -0.3, 0.2], POSE_TOL), `the box's mesh is at ${vec(box.p)}, expected [0.5, -0.3, 0.2]`);
      check(near(rotate(box.q, [1, 0, 0]), [1, 0, 0], POSE_TOL) && near(rotate(box.q, [0, 0, 1]), [0, 0, 1], POSE_TOL),
        `the box's mesh is turned (quaternion [x, y, z, w] ${vec(box.q)}), expected unturned`);
      return `after ${got.ms} ms: cylinder r ${fmt(c.radiusTop)} h ${fmt(c.height)} at ${vec(cyl.p)}, axis ${vec(axis)};`
        + ` box ${b.width} × ${b.height} × ${b.depth} at ${vec(box.p)}`;
    });
  } catch (e) {
    if (!(e instanceof Failure)) report(false, 'unexpected error', (e && e.stack) || String(e));
    else if (!results.some((r) => !r.ok)) report(false, 'setup', e.message);
  } finally {
    if (context) await context.close().catch(() => {});
    await stopServer(server);
    await stopServer(replayServer);
    await stopServer(restarted);
    await stopServer(sceneServer);
    fs.rmSync(userDataDir, { recursive: true, force: true });
    if (sceneDir) fs.rmSync(sceneDir, { recursive: true, force: true });
    consoleLog.end();
    clearTimeout(watchdog);
  }
  const failed = results.filter((r) => !r.ok);
  const total = `${((Date.now() - started) / 1000).toFixed(1)} s`;
  console.log(failed.length === 0 ? `all ${results.length} steps passed in ${total}`
    : `${failed.length} of ${results.length} steps failed (${total})`);
  return failed.length === 0 && results.length > 0 ? 0 : 1;
}

main().then((code) => process.exit(code), (e) => {
  console.log(`FAIL ${e instanceof Failure ? e.message : (e && e.stack) || e}`);
  process.exit(1);
});
