// labsim view: a chart of the numeric columns the student picks, over simulated time, for the
// selected robot. History is kept for every robot and column: each frame brings samples of the
// ticks since the last one (the server picks them) and its own values. Each picked signal has
// its own y scale, so that a swing of 0.5 m beside a tension of 2,000 N is not a flat line:
// the first four get an axis in their colour, and the legend above shows every one's value now.
"use strict";
window.LV = window.LV || {};
const HISTORY = 20000;  // samples kept per robot; the oldest half goes when it is full
const AXES = 4;  // signals with an axis of their own; beyond, a signal is drawn to its own scale, unmarked

LV.Chart = class {
  constructor(el, legend) {
    this.el = el;
    this.legend = legend;
    this.plot = null;
    this.picked = [];  // column indices
    this.columns = [];
    this.robot = 0;
    this.drawn = {};  // per series, what its envelope drew (canvas pixels per column; the browser tests read it)
    this.reset([], 0);
    new ResizeObserver(() => this._size()).observe(el);
  }

  // a new run: new columns, no history, nothing picked until setPicked
  reset(columns, robots) {
    this.columns = columns;
    this.picked = [];
    // per row, the time at the other end of the group of ticks it stands for (its own: one tick)
    // and per column "1" where the row is a band over that group (the column went up and down in it)
    this.history = Array.from({ length: robots }, () => ({ t: [], span: [], band: [], cols: columns.map(() => []) }));
    this._rebuild();
  }

  add(frame) {
    (frame.robots || []).forEach((r, i) => {
      const h = this.history[i];
      if (!r || !h) return;
      const t = frame.time;
      if (h.t.length && t < h.t[h.t.length - 1]) { h.t.length = 0; h.span.length = 0; h.band.length = 0; h.cols.forEach((c) => { c.length = 0; }); }
      const rows = r.samples || [], bands = r.bands || [], pairs = 2 * bands.length;
      // a pair (a group's least and greatest values, at its first and last tick) spans the group
      rows.forEach((s, k) => this._push(h, s[0], s.slice(1), k < pairs ? rows[k ^ 1][0] : s[0],
                                        k < pairs ? bands[k >> 1] : ""));
      if (frame.ran !== 0) {  // before the first tick there are no values yet
        this._push(h, t, r.values, t, "");
        h.now = r.values;  // as sent: "inf" stays "inf" in the legends (the lines have a gap there)
      }
      if (h.t.length > HISTORY) {
        const cut = HISTORY / 2; h.t.splice(0, cut); h.span.splice(0, cut); h.band.splice(0, cut); h.cols.forEach((c) => c.splice(0, cut));
      }
    });
  }

  // the run so far (a history message): each robot's rows [time, value, ...], replacing what was kept
  setHistory(robots, spans, bands) {
    this.history.forEach((h, i) => {
      h.t.length = 0; h.span.length = 0; h.band.length = 0; h.cols.forEach((c) => { c.length = 0; }); h.now = null;
      const sp = (spans && spans[i]) || [], bd = (bands && bands[i]) || [];
      (robots[i] || []).forEach((s, k) => this._push(h, s[0], s.slice(1), typeof sp[k] === "number" ? sp[k] : s[0],
                                                      typeof bd[k] === "string" ? bd[k] : ""));
    });
  }

  _push(h, t, values, span, band) {
    if (h.t.length && t <= h.t[h.t.length - 1]) return;
    h.t.push(t);
    h.span.push(span);
    h.band.push(band);
    h.cols.forEach((c, k) => c.push(typeof values[k] === "number" ? values[k] : null));
  }

  setPicked(picks) { this.picked = picks.slice(); this._rebuild(); }

  toggle(k, on) {
    this.picked = this.picked.filter((q) => q !== k);
    if (on) this.picked.push(k);
    this._rebuild();
  }

  select(robot) { this.robot = robot; this._rebuild(); }

  _colour(i) { return LV.PALETTE[(i + 3) % LV.PALETTE.length]; }

  _rebuild() {
    if (this.plot) { this.plot.destroy(); this.plot = null; }
    this.el.innerHTML = "";
    this._legend();
    if (!this.picked.length) { this.el.innerHTML = '<p class="muted">No signal picked.</p>'; return; }
    // every axis at least three labelled ticks: a flat signal gets a range around its value,
    // and ticks may stand 28 px apart on a 180 px chart (uPlot's default of 50 gave one or two)
    const scales = { x: { time: false, range: (u, lo, hi) => (lo === null ? [0, 1] : [lo, hi > lo ? hi : lo + 1]) } }, axes = [{ label: "", splits: LV.splits(6), values: (u, vs) => vs.map((v) => LV.fmtAxis(v)) }];
    const series = [{ label: "time (s)" }].concat(this.picked.map((k, i) => {
      scales["s" + i] = { auto: true, range: LV.range };
      if (i < AXES) {
        axes.push({ scale: "s" + i, side: i % 2 ? 1 : 3, stroke: this._colour(i), size: 56, splits: LV.splits(4),
                    grid: { show: i === 0 }, values: (u, vs) => vs.map((v) => LV.fmtAxis(v)) });
      }
      return {
        label: this.columns[k].name + (this.columns[k].group === "metric" ? " (metric)" : ""), scale: "s" + i,
        stroke: this._colour(i), width: 1.5, spanGaps: false, points: { show: false }, paths: this._envelope(k),
        value: (u, v, _s, idx) => this._value(k, v, idx),
      };
    }));
    this.plot = new uPlot({ width: this._w(), height: 180, series, legend: { live: true }, scales, axes },
                          this._data(), this.el);
  }

  // A series (column k) drawn as PlotJuggler and uPlot users expect at any speed: per pixel column,
  // the least and greatest value of every row that covers it (a row covers the columns from its
  // time to its span's other end when the pair it is in is a band for this column: the column went
  // up and down within that group of ticks; else only its own), a vertical stroke
  // between them, joined to the next column from the last value. A signal that flips sign within
  // a column fills a band; a slow one, one value a column, is its line. A null is a gap.
  _envelope(k) {
    return (u, si, i0, i1) => {
      const xs = u.data[0], ys = u.data[si], h = this.history[this.robot], span = h ? h.span : [], band = h ? h.band : [];
      const sy = u.series[si].scale, left = Math.floor(u.bbox.left), w = Math.ceil(u.bbox.width) + 2;
      const lo = new Float64Array(w).fill(NaN), hi = new Float64Array(w), first = new Float64Array(w);
      const last = new Float64Array(w), gapBefore = new Uint8Array(w);
      let gap = false;
      for (let i = i0; i <= i1; i++) {
        const y = ys[i];
        if (typeof y !== "number" || !Number.isFinite(y)) { gap = true; continue; }
        // a row covers its group's columns where the column went up and down in it, else its own
        const py = u.valToPos(y, sy, true), other = band[i] && band[i][k] === "1" ? span[i] : xs[i];
        const a = Math.max(0, Math.round(u.valToPos(Math.min(xs[i], other), "x", true)) - left);
        const b = Math.min(w - 1, Math.round(u.valToPos(Math.max(xs[i], other), "x", true)) - left);
        for (let c = a; c <= b; c++) {
          if (Number.isNaN(lo[c])) { lo[c] = hi[c] = first[c] = py; gapBefore[c] = gap ? 1 : 0; }
          else { if (py < lo[c]) lo[c] = py; if (py > hi[c]) hi[c] = py; }
          last[c] = py;
        }
        gap = false;
      }
      const path = new Path2D();
      let open = false;
      for (let c = 0; c < w; c++) {
        if (Number.isNaN(lo[c])) continue;
        const x = left + c;
        if (!open || gapBefore[c]) path.moveTo(x, first[c]); else path.lineTo(x, first[c]);
        open = true;
        if (hi[c] - lo[c] >= 0.5) { path.moveTo(x, lo[c]); path.lineTo(x, hi[c]); path.moveTo(x, last[c]); }
        else path.lineTo(x, last[c]);
      }
      this.drawn[si] = { columns: w, band: Array.from(lo, (v, c) => (Number.isNaN(v) ? null : hi[c] - v)) };
      return { stroke: path, fill: null, clip: null };
    };
  }

  _value(k, v, idx) {  // a legend's value, as the table prints it; the last tick's even when not a number
    if (v !== null && v !== undefined) return LV.fmt(v);
    const h = this.history[this.robot];
    return h && h.now && idx === h.t.length - 1 ? LV.fmt(h.now[k]) : "–";
  }

  _data() {
    const h = this.history[this.robot] || { t: [], cols: [] };
    return [h.t].concat(this.picked.map((k) => h.cols[k] || []));
  }

  // the values now, one per picked signal, in its colour (uPlot's legend shows them under the cursor)
  _legend() {
    if (!this.legend) return;
    const h = this.history[this.robot];
    if (this.legend.children.length !== this.picked.length) {
      this.legend.innerHTML = "";
      this.picked.forEach((k, i) => {
        const s = document.createElement("span");
        s.className = "now"; s.style.color = this._colour(i);
        this.legend.appendChild(s);
      });
    }
    this.picked.forEach((k, i) => {
      const col = h && h.cols[k], v = h && h.now ? h.now[k] : (col && col.length ? col[col.length - 1] : null);
      const s = this.legend.children[i];
      // written only when changed: the same text written again still costs a style and layout pass
      const colour = this._colour(i);
      if (s.dataset.column !== String(k)) s.dataset.column = String(k);
      if (s.dataset.colour !== colour) { s.dataset.colour = colour; s.style.color = colour; }
      const text = `${this.columns[k].name} ${LV.fmt(v)}`;
      if (s.textContent !== text) s.textContent = text;
    });
  }

  _w() { return Math.max(200, this.el.clientWidth - 10); }

  _size() { if (this.plot) this.plot.setSize({ width: this._w(), height: 180 }); }

  draw() {
    this._legend();
    if (!this.plot) return;
    const data = this._data();
    this.plot.setData(data);
    // away from the cursor, uPlot's legend says "--": show the last tick's values instead
    if (this.plot.cursor.left < 0 && data[0].length) this.plot.setLegend({ idx: data[0].length - 1 });
  }
};

// a scale's range: the data's, a little wider; a flat line (or none) gets room around it, so
// that its axis still has ticks to label
LV.range = (u, lo, hi) => {
  if (lo === null || hi === null || !Number.isFinite(lo) || !Number.isFinite(hi)) return [0, 1];
  if (hi - lo < 1e-12 * Math.max(1, Math.abs(lo))) { const d = Math.abs(lo) * 0.1 || 1; return [lo - d, hi + d]; }
  const pad = (hi - lo) * 0.05;
  return [lo - pad, hi + pad];
};

// an axis' ticks: round numbers (1, 2, 2.5 or 5 times a power of ten) at least `parts` of them
// across its range, so that every axis has at least three labels however small its range
LV.splits = (parts) => (u, axis, lo, hi) => {
  if (!(hi > lo)) return [lo];
  const raw = (hi - lo) / parts, p = Math.pow(10, Math.floor(Math.log10(raw)));
  const step = [5, 2.5, 2, 1].map((m) => m * p).find((s) => s <= raw) || p;
  const out = [];
  for (let v = Math.ceil(lo / step) * step; v <= hi + step * 1e-9 && out.length < 50; v += step) {
    out.push(Math.abs(v) < step * 1e-9 ? 0 : Number(v.toPrecision(12)));
  }
  return out;
};

// an axis tick: short, whatever the scale (0.0012, 2,000, 1.5e+6)
LV.fmtAxis = (v) => {
  if (v === null || v === undefined) return "";
  const a = Math.abs(v);
  if (a !== 0 && (a >= 1e5 || a < 1e-3)) return v.toExponential(1);
  return String(Number(v.toPrecision(4)));
};
