// Live plots of the tracking error and the clearance over the last 10 s of simulated time, one line per arm.
import { css } from './colors.js';

const WINDOW_S = 10;

export class Plots {
  constructor(canvas, legend) {
    this.canvas = canvas;
    this.legend = legend;
    this.ctx = canvas.getContext('2d');
    this.series = [];  // per arm: [{t, error, clearance}]
    this.labels = [];
    this.colors = [];
    this.dirty = true;
  }

  // one line per arm, in the given colours; clears the history when the arms change.
  setArms(labels, colors) {
    if (JSON.stringify(labels) !== JSON.stringify(this.labels)) this.series = labels.map(() => []);
    this.labels = labels;
    this.colors = colors;
    this.legend.replaceChildren(...labels.map((label, i) => {
      const item = document.createElement('span');
      const sw = document.createElement('span');
      sw.className = 'swatch';
      sw.style.background = css(colors[i]);
      item.append(sw, label);
      return item;
    }));
    this.dirty = true;
  }

  push(frame) {
    const arms = frame.arms || [];
    arms.forEach((a, i) => {
      const s = this.series[i];
      if (!s) return;
      if (s.length && frame.t < s[s.length - 1].t) s.length = 0;  // a reset or a seek back: start over
      if (s.length && frame.t === s[s.length - 1].t) return;      // paused
      s.push({ t: frame.t, error: a.error, clearance: a.clearance });
      while (s.length && s[0].t < frame.t - WINDOW_S) s.shift();
    });
    this.now = frame.t;
    this.dirty = true;
  }

  draw() {
    if (!this.dirty) return;
    this.dirty = false;
    const dpr = window.devicePixelRatio || 1;
    const w = this.canvas.clientWidth, h = this.canvas.clientHeight;
    if (this.canvas.width !== Math.round(w * dpr) || this.canvas.height !== Math.round(h * dpr)) {
      this.canvas.width = Math.round(w * dpr);
      this.canvas.height = Math.round(h * dpr);
    }
    const ctx = this.ctx;
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.clearRect(0, 0, w, h);
    const half = h / 2;
    this.panel(0, half, 'error', 'tracking error ‖p_E − p_T‖ [mm]', 0);
    this.panel(half, h - half, 'clearance', 'clearance: arm to nearest obstacle [mm]', null);
  }

  panel(y0, height, key, title, floor) {
    const ctx = this.ctx, w = this.canvas.clientWidth;
    const left = 36, right = 6, top = y0 + 16, bottom = y0 + height - 14;
    const t1 = this.now ?? 0, t0 = t1 - WINDOW_S;
    let lo = floor ?? Infinity, hi = -Infinity;
    for (const s of this.series) for (const p of s) {
      const v = p[key];
      if (v === null || v === undefined || !Number.isFinite(v)) continue;
      lo = Math.min(lo, v);
      hi = Math.max(hi, v);
    }
    if (!Number.isFinite(lo)) lo = 0;
    if (!Number.isFinite(hi) || hi - lo < 0.02) hi = lo + 0.02;
    hi += 0.08 * (hi - lo);
    const x = (t) => left + ((t - t0) / WINDOW_S) * (w - left - right);
    const y = (v) => bottom - ((v - lo) / (hi - lo)) * (bottom - top);

    ctx.font = '10px system-ui, sans-serif';
    ctx.fillStyle = '#445';
    ctx.fillText(title, left, y0 + 11);
    ctx.strokeStyle = '#dde2e8';
    ctx.lineWidth = 1;
    ctx.beginPath();
    for (let k = 0; k <= 4; ++k) {
      const v = lo + ((hi - lo) * k) / 4;
      ctx.moveTo(left, y(v));
      ctx.lineTo(w - right, y(v));
      ctx.fillText(`${Math.round(v * 1000)}`, 2, y(v) + 3);
    }
    ctx.stroke();
    if (lo < 0 && hi > 0) {
      ctx.strokeStyle = '#c44';
      ctx.beginPath();
      ctx.moveTo(left, y(0));
      ctx.lineTo(w - right, y(0));
      ctx.stroke();
    }
    ctx.fillText(`${WINDOW_S} s`, w - right - 22, bottom + 11);

    ctx.lineWidth = 1.5;
    this.series.forEach((s, i) => {
      ctx.strokeStyle = css(this.colors[i] || [0, 0, 0]);
      ctx.beginPath();
      let pen = false;
      for (const p of s) {
        const v = p[key];
        if (v === null || v === undefined || !Number.isFinite(v)) { pen = false; continue; }
        if (pen) ctx.lineTo(x(p.t), y(v)); else ctx.moveTo(x(p.t), y(v));
        pen = true;
      }
      ctx.stroke();
    });
  }
}
