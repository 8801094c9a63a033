// labsim view: the world on a canvas, to scale. World frame: x east (or along the arm), y north
// (or z up), metres; the canvas' y grows down. Pan with a drag, zoom with the wheel.
"use strict";
window.LV = window.LV || {};

LV.PALETTE = ["#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#bcbd22", "#17becf"];
LV.robotColour = (i) => LV.PALETTE[i % LV.PALETTE.length];
const PATH_POINTS = 3000;  // a robot's fading path: the last points where it bent
const LOCATOR = 10;  // the radius, CSS pixels, of the ring that finds a robot drawn smaller than it can be seen
const HITS = 2000;  // collision marks kept per robot (and count metrics' marks)
// a count metric's colour, by its place among the count metrics: the map's (runtime/pictures/paint.py)
LV.EVENT_RGB = ["#ffc107", "#009688", "#9c27b0", "#e91e63", "#3f51b5", "#8bc34a", "#795548", "#00bcd4"];

LV.centre = (corners) => [corners.reduce((a, p) => a + p[0], 0) / corners.length,
                          corners.reduce((a, p) => a + p[1], 0) / corners.length];
LV.inside = (corners, x, y) => {  // a point in a polygon (even-odd)
  let inside = false;
  for (let i = 0, j = corners.length - 1; i < corners.length; j = i++) {
    const [xi, yi] = corners[i], [xj, yj] = corners[j];
    if ((yi > y) !== (yj > y) && x < (xj - xi) * (y - yi) / (yj - yi) + xi) inside = !inside;
  }
  return inside;
};

LV.WorldView = class {
  constructor(canvas, onPick, onPlace) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d");
    this.onPick = onPick;
    this.onPlace = onPlace;  // (robot, x, y, heading): a robot dragged to a new pose; null: no dragging
    this.ghost = null;  // the pose a robot is being dragged to: {i, x, y, th}
    this.onBlock = null;  // (message): a block moved, added or removed; null: no changing blocks
    this.adding = false;  // the next click on the canvas adds a block there
    this.pickedBlock = null;  // the number of the block last clicked (Remove block removes it)
    this.blockGhost = null;  // where a dragged block would go: {k, dx, dy}
    this.scene = null;
    this.frame = null;
    this.selected = 0;
    this.paths = [];
    this.drawn = [];  // each robot's pose on the canvas, CSS pixels (tests read it)
    this.drawnTick = null;  // the tick of the frame last drawn
    this.labels = [];  // each robot's name label on the canvas (labels.js lays them out)
    this.scale = 40; this.cx = 0; this.cy = 0;  // px per m, the world point at the centre
    // the canvas' size in CSS pixels: reading clientWidth is a call into the layout engine, and
    // toPx runs for every point of every path on every frame (it was a tenth of the page's time)
    this.w = canvas.clientWidth; this.h = canvas.clientHeight;
    // what does not move (grid, ground, walls) drawn once per view to a canvas of its own, and
    // copied in each frame; `backdropKey` says for which pan, zoom and size it was drawn
    this.backdrop = document.createElement("canvas");
    this.backdropKey = null;
    this._pointer();
    // a new size (a window turned, a panel opened) fits the world again, unless the view was moved by hand
    this.moved = false;
    new ResizeObserver(() => { if (this.moved) { this._resize(); this.draw(); } else this.fit(); }).observe(canvas);
  }

  setScene(scene) {
    this.scene = scene;
    this.frame = null;
    this.backdropKey = null;
    this.paths = (scene.robots || []).map(() => []);
    this.hits = (scene.robots || []).map(() => []);  // where each collision began: a red cross there
    this.counted = (scene.robots || []).map(() => []);  // where a count metric rose (a near miss): [k, x, y]
    this._resize();
    this.fit();
  }

  setFrame(frame) {
    const back = this.frame && frame.tick < this.frame.tick;
    this.frame = frame;
    (frame.robots || []).forEach((r, i) => {
      if (!r || !r.pose || !this.paths[i]) return;
      const [x, y] = r.pose;
      if (typeof x !== "number" || typeof y !== "number") return;
      if (back) { this.paths[i] = []; this.hits[i] = []; this.counted[i] = []; }
      for (const q of (back ? [] : r.marks || [])) if (typeof q[1] === "number") this.counted[i].push(q);
      if (this.counted[i].length > HITS) this.counted[i].splice(0, this.counted[i].length - HITS);
      for (const q of (back ? [] : r.hits || [])) if (typeof q[0] === "number") this.hits[i].push(q);
      if (this.hits[i].length > HITS) this.hits[i].splice(0, this.hits[i].length - HITS);
      const p = this.paths[i];
      // the points where the path bent since the last frame (the server keeps them), then the pose;
      // a null point is a jump (the robot was put somewhere else): no line across it
      for (const q of (back ? [] : r.path || [])) p.push(typeof q[0] === "number" ? q : null);
      const last = p[p.length - 1];
      if (!last || last[0] !== x || last[1] !== y) p.push([x, y]);
      if (p.length > PATH_POINTS) p.splice(0, p.length - PATH_POINTS);
    });
  }

  // the path so far (a history message): a null point, or one with a null in it, is a jump
  setHistory(paths, hits, marks) {
    this.paths = (this.scene.robots || []).map((_, i) => (paths[i] || [])
      .map((q) => (q && typeof q[0] === "number" && typeof q[1] === "number" ? q : null)).slice(-PATH_POINTS));
    this.hits = (this.scene.robots || []).map((_, i) => ((hits && hits[i]) || []).slice(-HITS));
    this.counted = (this.scene.robots || []).map((_, i) => ((marks && marks[i]) || []).slice(-HITS));
    this.frame = null;  // the next frame follows on from the history, whatever tick it shows
  }

  bounds() {
    const w = this.scene && this.scene.world;
    if (!w) {  // no world: the robots' poses
      const pts = (this.frame ? this.frame.robots : []).filter((r) => r && r.pose).map((r) => r.pose);
      if (!pts.length) return [-5, -5, 5, 5];
      const xs = pts.map((p) => p[0]), ys = pts.map((p) => p[1]);
      return [Math.min(...xs) - 3, Math.min(...ys) - 3, Math.max(...xs) + 3, Math.max(...ys) + 3];
    }
    let [x0, y0, x1, y1] = w.bounds;
    const g = w.ground;
    if (g) for (const r of g.roads) for (const p of r.points) {
      x0 = Math.min(x0, p[0] - r.width); x1 = Math.max(x1, p[0] + r.width);
      y0 = Math.min(y0, p[1] - r.width); y1 = Math.max(y1, p[1] + r.width);
    }
    return [x0, y0, x1, y1];
  }

  fit() {
    const [x0, y0, x1, y1] = this.bounds();
    this._resize();
    const w = this.w || 600, h = this.h || 400;
    this.scale = Math.min(w / ((x1 - x0) * 1.08), h / ((y1 - y0) * 1.08));
    this.cx = (x0 + x1) / 2; this.cy = (y0 + y1) / 2;
    this.draw();
  }

  toPx(x, y) {
    return [this.w / 2 + (x - this.cx) * this.scale, this.h / 2 - (y - this.cy) * this.scale];
  }

  toWorld(px, py) {
    return [this.cx + (px - this.w / 2) / this.scale, this.cy - (py - this.h / 2) / this.scale];
  }

  _measure() { this.w = this.canvas.clientWidth; this.h = this.canvas.clientHeight; }

  _resize() {
    const dpr = window.devicePixelRatio || 1;
    this._measure();
    const w = this.w, h = this.h;
    if (this.canvas.width !== Math.round(w * dpr) || this.canvas.height !== Math.round(h * dpr)) {
      this.canvas.width = Math.round(w * dpr); this.canvas.height = Math.round(h * dpr);
    }
    this.ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  }

  _pointer() {
    const c = this.canvas;
    let drag = null;
    c.addEventListener("pointerdown", (e) => {
      // on a robot (live): drag it somewhere else, or with Shift turn it; elsewhere: pan
      const grab = this.onPlace ? this._robotAt(e.offsetX, e.offsetY) : -1;
      const block = grab < 0 && this.onBlock ? this._blockAt(e.offsetX, e.offsetY) : null;
      drag = { x: e.offsetX, y: e.offsetY, cx: this.cx, cy: this.cy, moved: false, robot: grab, turn: e.shiftKey, block };
      c.setPointerCapture(e.pointerId);
    });
    c.addEventListener("pointermove", (e) => {
      if (!drag) return;
      const dx = e.offsetX - drag.x, dy = e.offsetY - drag.y;
      if (Math.abs(dx) + Math.abs(dy) > 3) { drag.moved = true; c.classList.add("dragging"); }
      if (drag.robot >= 0) { if (drag.moved) this._dragRobot(drag, e.offsetX, e.offsetY); return; }
      if (drag.block !== null) {  // a block follows the pointer, drawn dashed until let go
        if (drag.moved) this.blockGhost = { k: drag.block, dx: dx / this.scale, dy: -dy / this.scale };
        this.draw(); return;
      }
      this.cx = drag.cx - dx / this.scale; this.cy = drag.cy + dy / this.scale;
      this.moved = true;
      this.draw();
    });
    c.addEventListener("pointerup", (e) => {
      if (drag && !drag.moved && this.adding && this.onBlock) {
        const [x, y] = this.toWorld(e.offsetX, e.offsetY);
        this.adding = false; c.classList.remove("adding");
        this.onBlock({ op: "add", x, y });
      } else if (drag && !drag.moved) {
        this.pickedBlock = drag.block;
        if (drag.block === null) this._pick(e.offsetX, e.offsetY);
      } else if (drag && drag.robot >= 0 && this.ghost) {
        const g = this.ghost;
        this.onPlace(g.i, g.x, g.y, g.th);
      } else if (drag && drag.block !== null && this.blockGhost) {
        const [cx, cy] = LV.centre(this.blocks().get(drag.block)), g = this.blockGhost;
        this.pickedBlock = drag.block;
        this.onBlock({ op: "move", block: drag.block, x: cx + g.dx, y: cy + g.dy });
      }
      this.ghost = null; this.blockGhost = null;
      drag = null; c.classList.remove("dragging");
      this.draw();
    });
    c.addEventListener("wheel", (e) => {
      e.preventDefault();
      const [wx, wy] = this.toWorld(e.offsetX, e.offsetY);
      this.scale *= Math.exp(-e.deltaY * 0.0015);
      this.scale = Math.min(5000, Math.max(0.5, this.scale));
      const [nx, ny] = this.toWorld(e.offsetX, e.offsetY);
      this.cx += wx - nx; this.cy += wy - ny;
      this.moved = true;
      this.draw();
    }, { passive: false });
    c.addEventListener("dblclick", () => { this.moved = false; this.fit(); });
  }

  _robotAt(px, py) {  // the robot drawn under a point of the canvas, or -1
    let best = -1, bestD = Math.max(12, 0.25 * this.scale);
    this.drawn.forEach((p, i) => {
      const d = p ? Math.hypot(p[0] - px, p[1] - py) : Infinity;
      if (d < bestD) { best = i; bestD = d; }
    });
    return best;
  }

  blocks() {  // the blocks as they stand: number -> corners (a frame has them once one changed)
    const listed = this.frame && this.frame.blocks;
    const w = this.scene && this.scene.world;
    return new Map(listed || (w ? w.blocks.map((c, k) => [k, c]) : []));
  }

  _blockAt(px, py) {  // the number of the block under a point of the canvas, or null
    const [x, y] = this.toWorld(px, py);
    let found = null;
    this.blocks().forEach((corners, k) => { if (LV.inside(corners, x, y)) found = k; });
    return found;
  }

  _dragRobot(drag, px, py) {  // where the dragged robot would go: moved with the pointer, or turned to face it
    const r = this.frame && this.frame.robots[drag.robot];
    if (!r || !r.pose) return;
    const [x, y, th] = r.pose, [wx, wy] = this.toWorld(px, py), [sx, sy] = this.toWorld(drag.x, drag.y);
    this.ghost = drag.turn ? { i: drag.robot, x, y, th: Math.atan2(wy - y, wx - x) }
      : { i: drag.robot, x: x + wx - sx, y: y + wy - sy, th };
    this.draw();
  }

  _pick(px, py) {
    let best = -1, bestD = 30;
    this.drawn.forEach((p, i) => {
      if (!p) return;
      const d = Math.hypot(p[0] - px, p[1] - py);
      if (d < bestD) { best = i; bestD = d; }
    });
    if (best >= 0 && this.onPick) this.onPick(best);
  }

  draw() {
    const ctx = this.ctx, w = this.w, h = this.h;
    if (!this.scene) { ctx.fillStyle = "#fafafa"; ctx.fillRect(0, 0, w, h); return; }
    const world = this.scene.world;
    this._backdrop();
    ctx.save(); ctx.setTransform(1, 0, 0, 1, 0, 0); ctx.drawImage(this.backdrop, 0, 0); ctx.restore();
    if (world) this._blocks();
    if (world && world.mechanism) this._mechanism(world.mechanism);
    else this._robots();
  }

  // the grid, the ground and the walls, drawn again only when the view moved or the canvas changed
  // size: a wall lab's 16 walls and its grid were redrawn for each of 20 frames a second
  _backdrop() {
    const c = this.canvas, key = [this.scale, this.cx, this.cy, c.width, c.height, this.w, this.h].join();
    if (key === this.backdropKey) return;
    this.backdropKey = key;
    const b = this.backdrop, main = this.ctx, world = this.scene.world;
    if (b.width !== c.width || b.height !== c.height) { b.width = c.width; b.height = c.height; }
    this.ctx = b.getContext("2d");  // the drawing helpers draw on this.ctx: point them at the backdrop
    try {
      this.ctx.setTransform(c.width / Math.max(1, this.w), 0, 0, c.height / Math.max(1, this.h), 0, 0);
      this.ctx.fillStyle = "#fafafa"; this.ctx.fillRect(0, 0, this.w, this.h);
      this._grid();
      if (world && world.ground) this._ground(world.ground);
      if (world) this._walls(world);
    } finally {
      this.ctx = main;
    }
  }

  _grid() {
    const ctx = this.ctx, w = this.w, h = this.h;
    const step = [0.1, 0.2, 0.5, 1, 2, 5, 10, 20, 50].find((s) => s * this.scale >= 40) || 100;
    const [x0, y1] = this.toWorld(0, 0), [x1, y0] = this.toWorld(w, h);
    ctx.strokeStyle = "#ececec"; ctx.lineWidth = 1; ctx.beginPath();
    for (let x = Math.ceil(x0 / step) * step; x <= x1; x += step) { const [px] = this.toPx(x, 0); ctx.moveTo(px, 0); ctx.lineTo(px, h); }
    for (let y = Math.ceil(y0 / step) * step; y <= y1; y += step) { const [, py] = this.toPx(0, y); ctx.moveTo(0, py); ctx.lineTo(w, py); }
    ctx.stroke();
    // the scale is said in the page, beside the world, not drawn in it where a block or a wall would hide it
    const label = document.getElementById("grid-scale"), text = `grid ${step} m`;
    if (label && label.textContent !== text) label.textContent = text;
  }

  _poly(points, close, from = 0, to = points.length) {  // points[from..to): a path's piece without a copy
    const ctx = this.ctx;
    ctx.beginPath();
    let pen = false;  // a null point lifts the pen
    for (let i = from; i < to; i++) {
      const p = points[i];
      if (!p) { pen = false; continue; }
      const [x, y] = this.toPx(p[0], p[1]);
      if (pen) ctx.lineTo(x, y); else ctx.moveTo(x, y);
      pen = true;
    }
    if (close) ctx.closePath();
  }

  _ground(g) {
    const ctx = this.ctx, rgb = (c) => `rgb(${c[0]},${c[1]},${c[2]})`;
    const [x0, y0, x1, y1] = this.bounds();
    const [a, b] = this.toPx(x0, y1), [c, d] = this.toPx(x1, y0);
    ctx.fillStyle = rgb(g.floor); ctx.fillRect(a, b, c - a, d - b);
    for (const p of g.patches) { this._poly(p.corners, true); ctx.fillStyle = rgb(p.rgb); ctx.fill(); }
    ctx.lineJoin = "round"; ctx.lineCap = "butt";
    for (const r of g.roads) {
      this._poly(r.points, r.closed);
      ctx.strokeStyle = rgb(r.rgb); ctx.lineWidth = Math.max(1, r.width * this.scale); ctx.stroke();
    }
    for (const l of g.lines) {
      this._poly([l.a, l.b], false);
      ctx.strokeStyle = rgb(l.rgb); ctx.lineWidth = Math.max(1, l.width * this.scale); ctx.stroke();
    }
  }

  _walls(world) {
    const ctx = this.ctx;
    ctx.lineCap = "square"; ctx.strokeStyle = "#373737";
    for (const [ax, ay, bx, by, t] of world.walls) {
      this._poly([[ax, ay], [bx, by]], false);
      ctx.lineWidth = Math.max(2, t * this.scale); ctx.stroke();
    }
    ctx.lineCap = "butt";
  }

  _blocks() {  // every frame: a block may be dragged, moved, added or removed
    const ctx = this.ctx;
    this.blocks().forEach((corners, k) => {
      this._poly(corners, true); ctx.fillStyle = "#b9b9b9"; ctx.fill();
      const picked = k === this.pickedBlock && this.onBlock;
      ctx.strokeStyle = picked ? "#111" : "#5f5f5f"; ctx.lineWidth = picked ? 3 : 1.5; ctx.stroke();
      const g = this.blockGhost;
      if (g && g.k === k) {  // where a dragged block goes when let go
        this._poly(corners.map((p) => [p[0] + g.dx, p[1] + g.dy]), true);
        ctx.setLineDash([5, 4]); ctx.strokeStyle = "#111"; ctx.lineWidth = 2; ctx.stroke(); ctx.setLineDash([]);
      }
    });
  }

  _robots() {
    const ctx = this.ctx, scene = this.scene, frame = this.frame;
    this.drawn = [];
    this.marks = [];
    this.drawnTick = frame ? frame.tick : null;
    scene.robots.forEach((robot, i) => {
      const path = this.paths[i] || [];
      const colour = LV.robotColour(i);
      // the fading path: older segments lighter
      const n = path.length, chunk = 30;
      ctx.strokeStyle = colour; ctx.lineWidth = i === this.selected ? 2.5 : 1.5; ctx.lineJoin = "round";
      for (let s = 0; s < n - 1; s += chunk) {
        ctx.globalAlpha = 0.08 + 0.75 * ((s + chunk) / n);
        this._poly(path, false, s, Math.min(n, s + chunk + 1)); ctx.stroke();
      }
      ctx.globalAlpha = 1;
      // where collisions began, a red cross each (as on the map labsim plot draws)
      ctx.strokeStyle = "#d62728"; ctx.lineWidth = 1.5; ctx.beginPath();
      for (const q of this.hits[i] || []) {
        const [hx, hy] = this.toPx(q[0], q[1]);
        ctx.moveTo(hx - 4, hy - 4); ctx.lineTo(hx + 4, hy + 4); ctx.moveTo(hx - 4, hy + 4); ctx.lineTo(hx + 4, hy - 4);
      }
      ctx.stroke();
      // where a count metric rose (a near miss), a triangle in its colour, as on the map
      for (const q of this.counted[i] || []) {
        const [mx, my] = this.toPx(q[1], q[2]);
        ctx.beginPath(); ctx.moveTo(mx, my - 5); ctx.lineTo(mx + 4.5, my + 3.5); ctx.lineTo(mx - 4.5, my + 3.5); ctx.closePath();
        ctx.fillStyle = LV.EVENT_RGB[q[0] % LV.EVENT_RGB.length]; ctx.fill();
        ctx.strokeStyle = "#333"; ctx.lineWidth = 0.75; ctx.stroke();
      }
      const r = frame && frame.robots[i];
      if (!r || !r.pose || typeof r.pose[0] !== "number") return;
      const [x, y, th] = r.pose, c = Math.cos(th), s = Math.sin(th);
      const local = (px, py) => [x + px * c - py * s, y + px * s + py * c];
      this._sonars(robot, r, local, th);
      // the robot at its model's size at every zoom: a body drawn bigger than the robot puts a
      // Pioneer inside the wall it is following
      const outline = robot.footprint.length ? robot.footprint : [[0.2, 0], [-0.15, 0.15], [-0.15, -0.15]];
      const body = Math.max(...outline.map((q) => Math.hypot(q[0], q[1]))) * this.scale;
      // too small to find at this zoom: a locator around it, a dashed ring and a tick the way it
      // heads, hollow and of fixed size, so that it cannot be taken for the robot's body
      const locator = body < LOCATOR / 2 ? LOCATOR : 0;
      if (locator) {
        const [px, py] = this.toPx(x, y);
        ctx.beginPath(); ctx.arc(px, py, locator, 0, 2 * Math.PI);
        ctx.strokeStyle = "rgba(255,255,255,0.75)"; ctx.lineWidth = 3; ctx.stroke();  // seen on a black road too
        ctx.setLineDash([3, 3]); ctx.strokeStyle = r.collided ? "#d62728" : colour;
        ctx.lineWidth = i === this.selected ? 2 : 1.25; ctx.stroke();
        ctx.setLineDash([]); ctx.beginPath();
        ctx.moveTo(px + locator * c, py - locator * s); ctx.lineTo(px + (locator + 6) * c, py - (locator + 6) * s);
        ctx.lineWidth = 2; ctx.stroke();
      }
      this._poly(outline.map((p) => local(p[0], p[1])), true);
      ctx.fillStyle = colour; ctx.globalAlpha = 0.85; ctx.fill(); ctx.globalAlpha = 1;
      // its edge no wider than a small body, so that the stroke does not make it look bigger
      ctx.lineWidth = Math.min(i === this.selected ? 3 : 1.5, Math.max(0.5, body / 4));
      ctx.strokeStyle = r.collided ? "#d62728" : (i === this.selected ? "#111" : "#333"); ctx.stroke();
      // the heading mark: half as far again as the robot reaches (an e-puck's 5 cm, a Pioneer's 32)
      const nose = local(1.5 * (robot.reach || 0.2), 0);
      this._poly([[x, y], nose], false); ctx.strokeStyle = "#111"; ctx.lineWidth = Math.min(2, Math.max(1, robot.reach * this.scale / 4)); ctx.stroke();
      this._groundSensors(robot, r, local);
      // what was drawn, in CSS pixels (the browser tests read it)
      this.marks[i] = { reach: body, locator,
                        nose: Math.hypot(...[0, 1].map((k) => this.toPx(...nose)[k] - this.toPx(x, y)[k])),
                        ground: (robot.ground || []).length, hits: (this.hits[i] || []).length,
                        counted: (this.counted[i] || []).length };
      this.drawn[i] = this.toPx(x, y);
    });
    this._labels();
    const g = this.ghost;
    if (g && scene.robots[g.i]) {  // where a dragged robot goes when let go
      const c = Math.cos(g.th), s = Math.sin(g.th), fp = scene.robots[g.i].footprint;
      this._poly((fp.length ? fp : [[0.2, 0], [-0.15, 0.15], [-0.15, -0.15]])
        .map((p) => [g.x + p[0] * c - p[1] * s, g.y + p[0] * s + p[1] * c]), true);
      ctx.setLineDash([5, 4]); ctx.strokeStyle = "#111"; ctx.lineWidth = 2; ctx.stroke(); ctx.setLineDash([]);
      const nose = 1.5 * (scene.robots[g.i].reach || 0.2);
      this._poly([[g.x, g.y], [g.x + nose * c, g.y + nose * s]], false); ctx.stroke();
    }
  }

  _labels() {  // after every robot, so that no robot covers another's name
    const ctx = this.ctx, robots = this.scene.robots;
    this.labels = [];  // each robot's label box, CSS pixels (tests read it)
    if (robots.length < 2) return;
    const font = (i) => `${i === this.selected ? "bold " : ""}11px system-ui`;
    const sizes = robots.map((r, i) => { ctx.font = font(i); return [ctx.measureText(r.name).width + 8, 15]; });
    const reach = Math.max(0, ...robots.map((r) => Math.max(0, ...r.footprint.map((p) => Math.hypot(p[0], p[1])))));
    const order = [this.selected].concat(robots.map((_, i) => i).filter((i) => i !== this.selected));
    const w = this.w, h = this.h;
    // a robot panned or zoomed out of sight has no label: one at the edge would point nowhere
    const seen = robots.map((_, i) => { const p = this.drawn[i]; return p && p[0] >= 0 && p[0] <= w && p[1] >= 0 && p[1] <= h ? p : null; });
    this.labels = LV.layoutLabels(seen, sizes, { width: w, height: h, marker: Math.min(40, Math.max(9, reach * this.scale)) }, order);
    this.labels.forEach((b, i) => {
      if (!b) return;
      const colour = LV.robotColour(i);
      if (b.leader) {
        const [ax, ay] = this.drawn[i];
        ctx.beginPath(); ctx.moveTo(ax, ay); ctx.lineTo(b.leader[0], b.leader[1]);
        ctx.strokeStyle = colour; ctx.lineWidth = 1; ctx.stroke();
      }
      ctx.fillStyle = "rgba(255,255,255,0.88)"; ctx.fillRect(b.x, b.y, b.w, b.h);
      ctx.strokeStyle = colour; ctx.lineWidth = i === this.selected ? 2 : 1;
      ctx.strokeRect(b.x + 0.5, b.y + 0.5, b.w - 1, b.h - 1);
      ctx.fillStyle = "#111"; ctx.font = font(i); ctx.textBaseline = "middle";
      ctx.fillText(robots[i].name, b.x + 4, b.y + b.h / 2 + 0.5); ctx.textBaseline = "alphabetic";
    });
  }

  // the ground sensors the behaviour reads, at their mounts: a square the grey of its reading
  // (0 black floor, 1 white), ringed in orange so that it shows on either
  _groundSensors(robot, r, local) {
    const ctx = this.ctx, side = Math.max(5, 0.008 * this.scale);
        (robot.ground || []).forEach((g, k) => {
      const v = r.ground ? r.ground[k] : null, [px, py] = this.toPx(...local(g.x, g.y));
      const grey = typeof v === "number" ? Math.round(255 * Math.max(0, Math.min(1, v))) : 200;
      ctx.fillStyle = `rgb(${grey},${grey},${grey})`; ctx.fillRect(px - side / 2, py - side / 2, side, side);
      ctx.strokeStyle = "#ff7f0e"; ctx.lineWidth = 1.5; ctx.strokeRect(px - side / 2, py - side / 2, side, side);
    });
  }

  _sonars(robot, r, local, th) {
    const ctx = this.ctx;
    robot.sonars.forEach((sonar, k) => {
      const d = r.sonars[k];
      const hit = typeof d === "number";
      const len = hit ? Math.min(d, sonar.range) : sonar.range;
      const [ax, ay] = local(sonar.x, sonar.y);
      const a = th + sonar.angle;
      const bx = ax + len * Math.cos(a), by = ay + len * Math.sin(a);
      this._poly([[ax, ay], [bx, by]], false);
      if (hit) {  // near is red, far is green
        const f = Math.max(0, Math.min(1, d / sonar.range));
        ctx.strokeStyle = `hsl(${Math.round(f * 120)}, 85%, 42%)`; ctx.setLineDash([]); ctx.lineWidth = 2;
      } else {
        ctx.strokeStyle = "rgba(120,120,120,0.6)"; ctx.setLineDash([4, 4]); ctx.lineWidth = 1;
      }
      ctx.stroke(); ctx.setLineDash([]);
      if (hit) {
        const [px, py] = this.toPx(bx, by);
        ctx.fillStyle = ctx.strokeStyle; ctx.beginPath(); ctx.arc(px, py, 3, 0, 2 * Math.PI); ctx.fill();
      }
    });
  }

  _bodyPose(m, name) {  // [x, z, angle] now, or the start pose
    const f = this.frame && this.frame.mechanism;
    if (f && f.bodies[name]) return f.bodies[name];
    const b = m.bodies.find((q) => q.name === name);
    return b ? [b.center[0], b.center[1], b.angle] : null;
  }

  _attached(m, bodyName, point) {  // a point fixed to a body, given where it was at the start
    const b = m.bodies.find((q) => q.name === bodyName);
    const now = this._bodyPose(m, bodyName);
    if (!b || !now) return point;
    const dx = point[0] - b.center[0], dz = point[1] - b.center[1], da = now[2] - b.angle;
    const c = Math.cos(da), s = Math.sin(da);
    return [now[0] + dx * c - dz * s, now[1] + dx * s + dz * c];
  }

  _mechanism(m) {
    const ctx = this.ctx, f = this.frame && this.frame.mechanism;
    const partial = f && f.partial;
    if (m.floor_z !== null && m.floor_z !== undefined) {
      const [x0, , x1] = this.bounds();
      this._poly([[x0 - 100, m.floor_z], [x1 + 100, m.floor_z]], false);
      ctx.strokeStyle = "#8a7f6a"; ctx.lineWidth = 3; ctx.stroke();
    }
    // ropes and cables first, under the bodies
    const cable = (a, b, colour) => { this._poly([a, b], false); ctx.strokeStyle = colour; ctx.lineWidth = 1.5; ctx.stroke(); };
    if (partial) {  // a replayed trace: a rope runs to its body, or to the next one the trace places
      const placed = m.bodies.filter((q) => f.bodies[q.name] && !q.static);
      for (const j of m.joints.filter((q) => q.rope && f.bodies[q.parent])) {
        const child = f.bodies[j.child] ? m.bodies.find((q) => q.name === j.child) : placed[placed.length - 1];
        if (child) cable(this._attached(m, j.parent, j.anchor),
                         this._attached(m, child.name, [child.center[0], child.center[1] + child.size[1] / 2]), "#444");
      }
    } else {
      for (const j of m.joints.filter((q) => q.rope)) {
        const child = m.bodies.find((q) => q.name === j.child);
        cable(this._attached(m, j.parent, j.anchor),
              this._attached(m, j.child, [child.center[0], child.center[1] + child.size[1] / 2]), "#444");
      }
      for (const s of m.force_sensors) {
        const [a, b] = s.anchors || s.between.map((n) => m.bodies.find((q) => q.name === n).center);
        cable(this._attached(m, s.between[0], a), this._attached(m, s.between[1], b), "#c47f00");
      }
    }
    for (const b of m.bodies) {
      if (partial && !b.static && !(f.bodies[b.name])) continue;
      const pose = this._bodyPose(m, b.name);
      const [w, h] = b.size, c = Math.cos(pose[2]), s = Math.sin(pose[2]);
      const corners = [[-w / 2, -h / 2], [w / 2, -h / 2], [w / 2, h / 2], [-w / 2, h / 2]]
        .map(([x, z]) => [pose[0] + x * c - z * s, pose[1] + x * s + z * c]);
      this._poly(corners, true);
      ctx.fillStyle = b.static ? "#9aa4ad" : (b.name === "Load" || b === m.bodies[m.bodies.length - 1] ? "#e07b39" : "#f2c12e");
      ctx.fill(); ctx.strokeStyle = "#333"; ctx.lineWidth = 1; ctx.stroke();
    }
    this._slewDial(m);
    if (partial && f.note) {  // say plainly what a replay cannot draw
      ctx.fillStyle = "#8a2d00"; ctx.font = "12px system-ui";
      ctx.fillText(f.note, 10, 18);  // at the top: the floor and the help line are at the bottom
    }
  }

  _slewDial(m) {  // the slew angle, seen from above, in a corner
    if (!m.slew) return;
    const f = this.frame && this.frame.mechanism;
    let a = 0;
    if (f && f.joints && f.joints[m.slew]) a = f.joints[m.slew][0];
    else if (f && typeof f.slew === "number") a = f.slew;
    // below the grid's scale, which stands over the world's top right corner (the page's, not drawn)
    const ctx = this.ctx, x = this.w - 60, y = 90, r = 40;
    ctx.fillStyle = "rgba(255,255,255,0.9)"; ctx.strokeStyle = "#999"; ctx.lineWidth = 1;
    ctx.beginPath(); ctx.arc(x, y, r, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
    ctx.strokeStyle = "#e07b39"; ctx.lineWidth = 4;
    ctx.beginPath(); ctx.moveTo(x, y); ctx.lineTo(x + r * 0.9 * Math.cos(a), y - r * 0.9 * Math.sin(a)); ctx.stroke();
    ctx.fillStyle = "#333"; ctx.font = "11px system-ui"; ctx.textAlign = "center";
    ctx.fillText(`slew ${(a * 180 / Math.PI).toFixed(1)}°`, x, y + r + 14);
    ctx.fillText("from above", x, y - r - 6); ctx.textAlign = "start";
    const half = ctx.measureText("from above").width / 2;  // where the dial and its captions are (the browser tests read it)
    this.dialBox = { left: x - Math.max(r, half), top: y - r - 18, right: x + Math.max(r, half), bottom: y + r + 18 };
  }
};
