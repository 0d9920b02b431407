// Time steps in the viewer: the "Time" panel of a time series (dataset.info's time_steps) with
// a slider over the steps, the step's time and name, and play/pause. The step lives in the
// view (view.timeStep), travels in the URL (step=) and goes to the server as time.set. While
// playing, each step is sent once the frame of the one before is on the screen, at most at
// the chosen rate (or as fast as frames come), with the step after it as time.set's prefetch,
// so that the server inflates its values while this step's frame is made. The frames of a
// play are interaction frames, not refined (the next step follows); Pause sends the step
// alone, which the server refines to a still.

const MAX_TIME_STEP = 99999;  // protocol/js/codec.js's (not imported: view-state.js imports this under node)

// ---------- the URL ----------

export function timeToHash(view) {
  return view.timeStep ? [`step=${view.timeStep}`] : [];
}

// Untrusted (a pasted link): a whole number in range, else step 0.
export function timeFromHash(h) {
  const text = h.get('step') ?? '';
  const step = /^\d{1,5}$/.test(text) ? Number(text) : 0;
  return { timeStep: step <= MAX_TIME_STEP ? step : 0 };
}

// ---------- the panel ----------

export class TimePanel {
  // host: { send(type, body) -> id, view(), saved() }
  constructor(root, host) {
    this.root = root;
    this.host = host;
    this.steps = [];
    this.playing = false;
    this.waitingFor = -1;  // the id of the time.set whose frame has not come yet
    this.lastSentAt = 0;
    this.timer = null;
    this.stats = { shown: 0, firstShownAt: 0, lastShownAt: 0 };  // steps shown while playing
    this.slider = root.querySelector('#time-step');
    this.label = root.querySelector('#time-label');
    this.play = root.querySelector('#time-play');
    this.rate = root.querySelector('#time-rate');
    this.slider.addEventListener('input', () => {
      this.pause();
      this.setStep(Number(this.slider.value));
    });
    this.play.addEventListener('click', () => (this.playing ? this.pause() : this.start()));
  }

  // A dataset opened: its steps, and the view's step when it has it.
  setDataset(info) {
    this.pause();
    this.steps = info.time_steps ?? [];
    const view = this.host.view();
    if (!(view.timeStep < this.steps.length)) view.timeStep = 0;
    this.root.hidden = this.steps.length < 2;
    this.slider.max = String(Math.max(0, this.steps.length - 1));
    this.show();
  }

  show() {
    const step = this.host.view().timeStep ?? 0;
    this.slider.value = String(step);
    const s = this.steps[step];
    this.label.textContent = s ? `step ${step + 1} of ${this.steps.length}   t = ${+s.time.toPrecision(6)}   ${s.name}` : '';
    this.play.textContent = this.playing ? 'Pause' : 'Play';
    this.play.setAttribute('aria-pressed', String(this.playing));
  }

  // time.set for the view's step (a series only), e.g. after a reconnect.
  send() {
    if (this.steps.length < 2) return;
    this.waitingFor = this.host.send('time.set', { step: this.host.view().timeStep ?? 0 });
  }

  setStep(step, prefetch) {
    const view = this.host.view();
    view.timeStep = Math.max(0, Math.min(this.steps.length - 1, step));
    const body = { step: view.timeStep };
    if (prefetch !== undefined) body.prefetch = prefetch;
    this.waitingFor = this.host.send('time.set', body);
    this.lastSentAt = performance.now();
    this.show();
    this.host.saved();
  }

  // Steps a second asked for: the rate chosen, or 0 for as fast as frames come.
  stepsPerSecond() {
    return Number(this.rate?.value ?? 0);
  }

  start() {
    if (this.steps.length < 2 || this.playing) return;
    this.playing = true;
    this.stats = { shown: 0, firstShownAt: 0, lastShownAt: 0 };
    this.show();
    this.advance();
  }

  pause() {
    if (!this.playing) return;
    this.playing = false;
    clearTimeout(this.timer);
    this.timer = null;
    // the step shown, alone: the server refines it to a still (a play's steps are not refined)
    this.waitingFor = this.host.send('time.set', { step: this.host.view().timeStep ?? 0 });
    this.show();
  }

  // The next step, once the frame of the one before came and the rate allows.
  advance() {
    if (!this.playing || this.waitingFor >= 0) return;
    const rate = this.stepsPerSecond();
    const wait = rate > 0 ? this.lastSentAt + 1000 / rate - performance.now() : 0;
    if (wait > 1) {
      clearTimeout(this.timer);
      this.timer = setTimeout(() => this.advance(), wait);
      return;
    }
    const n = this.steps.length;
    const next = ((this.host.view().timeStep ?? 0) + 1) % n;
    this.setStep(next, (next + 1) % n);
  }

  // A frame is on the screen: a step's first frame lets the play go on.
  onFrame(header) {
    if (this.waitingFor < 0 || header.message_id < this.waitingFor) return;
    this.waitingFor = -1;
    if (this.playing) {
      const now = performance.now();
      if (!this.stats.shown) this.stats.firstShownAt = now;
      this.stats.shown += 1;
      this.stats.lastShownAt = now;
      this.advance();
    }
  }

  // Steps a second shown while playing: over the steps after the first.
  measuredRate() {
    const s = this.stats;
    return s.shown > 1 ? ((s.shown - 1) * 1000) / (s.lastShownAt - s.firstShownAt) : 0;
  }
}
