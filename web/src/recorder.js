// Record: keeps the frames the page receives and downloads them as a replay file (docs/viewer.md, "Replay files")
// when recording stops. The file holds one hello, and `rmpmarl view --replay` wants strictly increasing times, so
// paused frames are skipped and a change of set-up or a reset ends the recording.

const MAX_FRAMES = 30 * 60 * 30;  // half an hour at 30 frames per second

export class Recorder {
  constructor(onStop) {
    this.onStop = onStop;  // (why) → void, after a recording ended by itself
    this.active = false;
  }

  start(helloText) {
    this.active = true;
    this.hello = helloText;
    this.frames = [];
    this.lastT = -Infinity;
  }

  // a new hello: a different set-up ends the recording.
  onHello(helloText, hello) {
    if (!this.active) return;
    const before = JSON.parse(this.hello);
    if (JSON.stringify(before.arms) !== JSON.stringify(hello.arms) || before.controller !== hello.controller) {
      this.stop();
      this.onStop('the set-up changed');
    }
  }

  onFrame(frameText, frame) {
    if (!this.active) return;
    if (frame.t < this.lastT) {
      this.stop();
      this.onStop('the episode was reset');
      return;
    }
    if (frame.t === this.lastT) return;
    this.lastT = frame.t;
    this.frames.push(frameText);
    if (this.frames.length >= MAX_FRAMES) {
      this.stop();
      this.onStop(`${MAX_FRAMES} frames recorded`);
    }
  }

  // ends the recording and downloads it; returns the number of frames.
  stop() {
    if (!this.active) return 0;
    this.active = false;
    const n = this.frames.length;
    const text = `{"format":"rmpmarl-replay","version":1,"hello":${this.hello},"frames":[${this.frames.join(',')}]}`;
    this.frames = [];
    const url = URL.createObjectURL(new Blob([text], { type: 'application/json' }));
    const a = document.createElement('a');
    const stamp = new Date().toISOString().replace(/[:.]/g, '-').slice(0, 19);
    a.href = url;
    a.download = `rmpmarl-replay-${stamp}.json`;
    document.body.appendChild(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(url), 10000);
    return n;
  }
}
