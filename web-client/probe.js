// The probe: a click on the image (a press and release without moving) asks the server for
// the field under the cursor (probe -> probe.result) and shows it beside the cursor: every
// point attribute there (vectors as components and magnitude), the one shown first.
import { probeRows } from '/protocol/js/planes.js';

const kClickSlop = 3;  // px a click may move

export class Probe {
  // host: { send(type, body) -> id }
  constructor(canvas, overlay, host) {
    this.canvas = canvas;
    this.overlay = overlay;
    this.host = host;
    this.asked = null;  // {id, left, top}
    this.last = null;   // the last probe.result
    let down = null;
    canvas.addEventListener('pointerdown', (e) => {
      down = e.button === 0 ? { x: e.clientX, y: e.clientY } : null;
    });
    canvas.addEventListener('pointerup', (e) => {
      if (!down || Math.hypot(e.clientX - down.x, e.clientY - down.y) > kClickSlop) return;
      down = null;
      this.ask(e.clientX, e.clientY);
    });
  }

  ask(clientX, clientY) {
    const rect = this.canvas.getBoundingClientRect();
    // the view.resize size is the canvas's pixel size
    const x = ((clientX - rect.left) / rect.width) * this.canvas.width, y = ((clientY - rect.top) / rect.height) * this.canvas.height;
    const id = this.host.send('probe', { x: Math.max(0, x), y: Math.max(0, y) });
    if (id >= 0) this.asked = { id, left: clientX - rect.left, top: clientY - rect.top };
  }

  // Forgets the probe asked (a double-click's clicks): its answer shows nothing.
  cancel() {
    this.asked = null;
    this.overlay.hidden = true;
  }

  // Beside the cursor, below and to the right, or on whichever side keeps it inside the view
  // (a phone's view is narrower than the popup of a vector's components).
  place() {
    const view = this.overlay.offsetParent?.getBoundingClientRect() ?? this.canvas.getBoundingClientRect();
    const { offsetWidth: w, offsetHeight: h } = this.overlay;
    const margin = 4, { left, top } = this.asked;
    const x = left + 12 + w <= view.width - margin ? left + 12 : Math.max(margin, Math.min(left - 12 - w, view.width - margin - w));
    const y = top + 12 + h <= view.height - margin ? top + 12 : Math.max(margin, Math.min(top - 12 - h, view.height - margin - h));
    Object.assign(this.overlay.style, { left: `${x}px`, top: `${y}px` });
  }

  // a probe.result from the server
  show(message) {
    this.last = message;
    if (!this.asked || message.id !== this.asked.id) return;
    const fmt = (v) => (v === null || !Number.isFinite(v) ? '-' : Math.abs(v) >= 1e4 || (Math.abs(v) < 1e-3 && v !== 0) ? v.toExponential(3) : v.toPrecision(4));
    const rows = probeRows(message).map((r) =>
      Array.isArray(r.value) ? `${r.name} = (${r.value.map(fmt).join(', ')}), |${r.name}| = ${fmt(r.magnitude)}` : `${r.name || 'value'} = ${fmt(r.value)}`,
    );
    this.overlay.textContent = message.hit
      ? `${rows.join('\n')}\nat (${message.position.map(fmt).join(', ')}) on the ${message.surface}`
      : 'nothing under the cursor';
    this.overlay.hidden = false;
    this.place();
    clearTimeout(this.timer);
    this.timer = setTimeout(() => (this.overlay.hidden = true), 6000);
  }
}
