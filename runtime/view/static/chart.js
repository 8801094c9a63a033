// labsim view: a chart of the numeric columns the student picks, over simulated time, for the
// selected robot. History is kept for every robot and column, one sample per frame.
"use strict";
window.LV = window.LV || {};
const HISTORY = 20000;  // samples kept per robot; the oldest half goes when it is full

LV.Chart = class {
  constructor(el) {
    this.el = el;
    this.plot = null;
    this.picked = [];  // column indices
    this.columns = [];
    this.robot = 0;
    this.reset([], 0);
    new ResizeObserver(() => this._size()).observe(el);
  }

  reset(columns, robots) {
    this.columns = columns;
    this.history = Array.from({ length: robots }, () => ({ t: [], cols: columns.map(() => []) }));
    this._rebuild();
  }

  add(frame) {
    (frame.robots || []).forEach((r, i) => {
      const h = this.history[i];
      if (!r || !h) return;
      const t = frame.time;
      if (h.t.length && t < h.t[h.t.length - 1]) { h.t.length = 0; h.cols.forEach((c) => { c.length = 0; }); }
      if (h.t.length && t === h.t[h.t.length - 1]) return;
      h.t.push(t);
      r.values.forEach((v, k) => { if (h.cols[k]) h.cols[k].push(typeof v === "number" ? v : null); });
      if (h.t.length > HISTORY) { const cut = HISTORY / 2; h.t.splice(0, cut); h.cols.forEach((c) => c.splice(0, cut)); }
    });
  }

  toggle(k, on) {
    this.picked = this.picked.filter((q) => q !== k);
    if (on) this.picked.push(k);
    this._rebuild();
  }

  select(robot) { this.robot = robot; this._rebuild(); }

  _rebuild() {
    if (this.plot) { this.plot.destroy(); this.plot = null; }
    this.el.innerHTML = "";
    if (!this.picked.length) { this.el.innerHTML = '<p class="muted">No signal picked.</p>'; return; }
    const series = [{ label: "time (s)" }].concat(this.picked.map((k, i) => ({
      label: this.columns[k].name + (this.columns[k].group === "metric" ? " (metric)" : ""),
      stroke: LV.PALETTE[(i + 3) % LV.PALETTE.length], width: 1.5, spanGaps: false, points: { show: false },
      value: (u, v) => (v === null || v === undefined ? "--" : LV.fmt(v)),  // as the table prints it
    })));
    this.plot = new uPlot({ width: this._w(), height: 180, series, legend: { live: true },
                            scales: { x: { time: false } }, axes: [{ label: "" }, {}] }, this._data(), this.el);
  }

  _data() {
    const h = this.history[this.robot] || { t: [], cols: [] };
    return [h.t].concat(this.picked.map((k) => h.cols[k] || []));
  }

  _w() { return Math.max(200, this.el.clientWidth - 10); }

  _size() { if (this.plot) this.plot.setSize({ width: this._w(), height: 180 }); }

  draw() { if (this.plot) this.plot.setData(this._data()); }
};
