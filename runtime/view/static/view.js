// labsim view: the page's connection and panels. The server sends a "scene" once per run and
// then "frame"s (docs/view.md); the page sends small JSON messages back. `window.labsimView`
// exposes the latest scene and frame (the browser tests read it).
"use strict";
const $ = (id) => document.getElementById(id);
const state = { scene: null, frame: null, frames: 0, robot: 0, ws: null, dragging: null, sent: {}, rows: [],
                sentValue: {}, touched: {},
                chartNames: null, editing: false, applied: false, pendingEdit: false, badLines: [],
                // the page's own cost, ms, summed over the frames (benchmarks/bench_view_browser.py reads it)
                cost: { parse: 0, frame: 0, draw: 0, chart: 0, draws: 0, charts: 0 }, chartAt: -Infinity };
const CHART_MS = 100;  // the chart is drawn again at most 10 times a second: its history is long
window.labsimView = state;

// a robot dragged on the canvas: the server puts it there (or says why not) and the trace records it
const placeRobot = (i, x, y, heading) => { notice(""); send({ type: "place", robot: i, x, y, heading }); };
const world = new LV.WorldView($("world"), (i) => selectRobot(i), placeRobot);
// a block dragged, added or removed: the same, through the backend and into the trace
const changeBlock = (msg) => { notice(""); send({ type: "block", ...msg }); blockTools(); };
const chart = new LV.Chart($("chart"), $("chart-now"));
window.LV_world = world;  // what is drawn where (the browser tests read it)
window.LV_chart = chart;

function send(msg) {
  if (state.ws && state.ws.readyState === WebSocket.OPEN) state.ws.send(JSON.stringify(msg));
}

// Reconnecting: after 1 s, then twice as long each time up to 30 s (a laptop asleep, a server
// restarted); not at all once the server said it ends (close code 4000: Ctrl-C, SIGTERM).
const RETRY_MS = [1000, 2000, 4000, 8000, 16000, 30000];
const GOODBYE = 4000;
function connect() {
  const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws`);
  state.ws = ws;
  ws.onopen = () => {
    state.retries = 0; state.offline = null;
    setStatus("connected", "ok"); send({ type: "select", robot: state.robot });
  };
  ws.onclose = (e) => {
    if (state.ws !== ws) return;
    if (e.code === GOODBYE) {
      offline("labsim view has stopped: this page shows the run as it last was. Start labsim view again and " +
              "open the address it prints.", "stopped");
      return;
    }
    const wait = RETRY_MS[Math.min(state.retries || 0, RETRY_MS.length - 1)];
    state.retries = (state.retries || 0) + 1;
    offline(`The connection to labsim view was lost (is it still running?). Trying again in ${wait / 1000} s` +
            " (attempt " + state.retries + "); if it was started again, open the new address it printed.",
            "disconnected: retrying…");
    setTimeout(connect, wait);
  };
  ws.onmessage = (e) => {
    let msg;
    const t0 = performance.now();
    try { msg = JSON.parse(e.data); } catch (err) { return; }
    const t1 = performance.now();
    state.cost.parse += t1 - t0;
    const handle = HANDLERS[msg.type];
    if (handle) { handle(msg); if (msg.type === "frame") state.cost.frame += performance.now() - t1; }
  };
}

// Gone: the page says so in a banner, and every control that would send something is off until
// a scene comes again (a reconnect). What is drawn stays, as it last was.
function offline(text, badge) {
  state.offline = text;
  setStatus(badge, "bad");
  const b = $("ended");
  b.hidden = false; b.className = "ended bad"; b.textContent = text;
  document.body.classList.add("offline");
  enableControls();
}

// What the page may still ask: nothing while offline; a finished run only Restart (and a
// replay's scrubber and Rewind); read-only, no Apply or Save.
function enableControls() {
  const f = state.frame, scene = state.scene, off = !!state.offline;
  const finished = !!(f && f.finished && !f.playing);
  const live = scene && scene.mode === "live" && scene.ok;
  for (const id of ["play", "step"]) $(id).disabled = off || finished || !scene || !scene.ok;
  $("restart").disabled = off || !scene;
  $("speed").disabled = off || finished;
  for (const el of document.querySelectorAll("#sliders input, #params input, #params button, #break-form input, " +
                                             "#break-form select, #break-form button, #breaks button, #timeline, " +
                                             "#add-block, #recheck")) {
    el.disabled = off || (finished && el.closest("#sliders") !== null);
  }
  $("apply").disabled = off || !live || !!scene.read_only;
  $("save").disabled = off || !live || !scene.can_save;
  $("save").title = scene && scene.mode === "live" && !scene.can_save && !scene.read_only
    ? "started with --no-token: saving from the page is off" : "write it over the file";
  $("scrubber").disabled = off;
}

function setStatus(text, kind) { const s = $("status"); s.textContent = text; s.className = "status " + (kind || ""); }

function notice(title, body, error) {
  const n = $("notice");
  n.hidden = !title;
  n.className = "notice" + (error ? " error" : "");
  n.innerHTML = "";
  if (!title) return;
  n.appendChild(document.createTextNode(title));
  if (body) { const pre = document.createElement("pre"); pre.textContent = body; n.appendChild(pre); }
}

// -- the scene: once per run --------------------------------------------------------------
function onScene(scene) {
  state.scene = scene;
  state.frame = null;
  if (!state.offline) { $("ended").hidden = true; document.body.classList.remove("offline"); }
  $("diagnostics").hidden = scene.ok;
  $("diagnostics-text").textContent = (scene.diagnostics || []).join("\n");
  editorScene(scene);
  if (!scene.ok) { setStatus("does not compile", "bad"); return; }
  setStatus(scene.mode === "replay" ? "replay" : "live", "ok");  // after "Check again" too
  notice(scene.diagnostics.length ? "Warnings:" : "", scene.diagnostics.join("\n"), false);
  $("name").textContent = scene.name || "labsim view";
  $("path").textContent = scene.path + (scene.mode === "replay" ? " (replay)" : "") + (scene.trace && scene.mode === "live" ? ` → ${scene.trace}` : "");
  document.title = `${scene.name || scene.path} – labsim view`;
  const replay = scene.mode === "replay";
  $("scrubber-row").hidden = !replay;
  if (replay) { $("scrubber").max = String(Math.max(0, scene.ticks - 1)); }
  $("restart").textContent = replay ? "Rewind" : "Restart";
  for (const row of document.querySelectorAll(".state-row, .rule-row")) row.hidden = !scene.rules.length && !replay;
  buildRobots(scene);
  buildSliders(scene);
  buildParams(scene);
  buildTable(scene);
  $("breaks-panel").hidden = scene.mode !== "live";
  breakHint(scene);
  state.breaksShown = null;
  chart.reset(scene.columns, scene.robots.length);
  listEvents([], 0, true);  // a new run: its own events
  buildCounts(scene);
  $("events-panel").hidden = replay;  // a replay's events are its trace's events column, in the table
  pickChart(scene);
  world.onPlace = scene.mode === "live" ? placeRobot : null;
  const blocks = scene.mode === "live" && scene.world && !scene.world.mechanism;
  world.onBlock = blocks ? changeBlock : null;
  world.pickedBlock = null; world.adding = false;
  $("block-tools").hidden = !blocks;
  blockTools();
  world.setScene(scene);
  if (state.robot >= scene.robots.length) selectRobot(0);
}

function blockTools() {  // Remove block: only with a block picked that still stands
  $("remove-block").disabled = world.pickedBlock === null || !world.blocks().has(world.pickedBlock);
  $("add-block").classList.toggle("on", world.adding);
}
$("add-block").addEventListener("click", () => {
  world.adding = !world.adding; $("world").classList.toggle("adding", world.adding); blockTools();
});
$("remove-block").addEventListener("click", () => {
  if (world.pickedBlock !== null) changeBlock({ op: "remove", block: world.pickedBlock });
  world.pickedBlock = null; blockTools();
});
$("world").addEventListener("pointerup", () => setTimeout(blockTools, 0));

function buildRobots(scene) {
  const sel = $("robot");
  sel.innerHTML = "";
  scene.robots.forEach((r, i) => {
    const o = document.createElement("option");
    o.value = String(i); o.textContent = r.model ? r.name : `${r.name} (mechanism)`;
    sel.appendChild(o);
  });
  sel.value = String(state.robot);
}

function buildSliders(scene) {
  const box = $("sliders");
  box.innerHTML = "";
  $("sliders-panel").hidden = !scene.sliders.length;
  $("timeline").checked = !!scene.timeline;
  $("timeline-row").hidden = scene.mode !== "live";
  for (const s of scene.sliders) {
    const div = document.createElement("div");
    div.className = "slider";
    div.innerHTML = `<div class="label"><span class="text"></span><span class="muted value"></span></div>`;
    const input = document.createElement("input");
    Object.assign(input, { type: "range", min: s.min, max: s.max, step: (s.max - s.min) / 200, value: s.value });
    input.dataset.name = s.name;
    input.setAttribute("aria-label", s.name);
    input.addEventListener("pointerdown", () => { state.dragging = s.name; });
    input.addEventListener("pointerup", () => { state.dragging = null; });
    input.addEventListener("input", () => {  // the value follows the thumb (or the keys), not the next frame
      state.touched[s.name] = performance.now();
      div.querySelector(".value").textContent = fmt(Number(input.value));
      moveSlider(s.name, Number(input.value));
    });
    // the last value, once let go: only when it was not sent already (one event in the trace, not two)
    input.addEventListener("change", () => { moveSlider(s.name, Number(input.value), true); state.dragging = null; });
    div.appendChild(input);
    div.querySelector(".text").textContent = s.name;  // its own name; its value beside it
    box.appendChild(div);
  }
  // the labels the sliders show, each once, as the script words it (the crane's three share one)
  const labels = [...new Set(scene.sliders.map((s) => s.label).filter((l) => l))];
  const list = $("slider-labels");
  list.innerHTML = "";
  for (const l of labels) {
    const d = document.createElement("div");
    d.className = "slider-label"; d.dataset.label = l;
    list.appendChild(d);
  }
}

function moveSlider(name, value, force) {  // at most 20 messages a second while dragging
  const now = performance.now(), last = state.sent[name] || 0;
  clearTimeout(state.sent[name + ":t"]);
  if (force && state.sentValue[name] === value) return;  // sent already: the trace records a move once
  if (force || now - last > 50) {
    state.sent[name] = now; state.sentValue[name] = value; send({ type: "slider", name, value });
  } else state.sent[name + ":t"] = setTimeout(() => moveSlider(name, value, true), 50 - (now - last));
}
const TOUCHED_MS = 800;  // a slider moved here is the page's for this long: a frame from before it does not undo it

function buildParams(scene) {
  const form = $("params");
  form.innerHTML = "";
  const names = Object.keys(scene.params || {});
  $("params-panel").hidden = !names.length;
  const live = scene.mode === "live";
  for (const n of names) {
    const label = document.createElement("label");
    label.textContent = n; label.htmlFor = "param-" + n;
    const input = document.createElement("input");
    input.type = "text"; input.id = "param-" + n; input.name = n; input.disabled = !live;
    input.value = n in scene.overrides ? scene.overrides[n] : String(scene.params[n]);
    input.dataset.start = input.value;
    form.appendChild(label); form.appendChild(input);
  }
  if (live && names.length) {
    const b = document.createElement("button");
    b.type = "submit"; b.className = "apply"; b.textContent = "Apply and restart";
    form.appendChild(b);
  }
}

$("params").addEventListener("submit", (e) => {
  e.preventDefault();
  const values = {};
  for (const input of $("params").querySelectorAll("input")) {
    if (input.value !== input.dataset.start) values[input.name] = input.value.trim();
  }
  notice("");
  send({ type: "params", values });
});

function buildTable(scene) {
  const body = $("table").querySelector("tbody");
  body.innerHTML = "";
  state.rows = [];
  let group = null;
  scene.columns.forEach((c, k) => {
    if (c.group !== group) {
      group = c.group;
      const tr = body.insertRow();
      tr.className = "group";
      const td = tr.insertCell(); td.colSpan = 3;
      td.textContent = { sensor: "sensors", signal: "signals", slider: "sliders", metric: "metrics", trace: "columns" }[group] || group;
    }
    const tr = body.insertRow();
    const box = document.createElement("input");
    box.type = "checkbox"; box.dataset.column = c.name;
    if (c.numeric === false) {  // an image or a record: nothing to chart, so nothing to tick
      box.disabled = true; box.hidden = true; tr.title = "not a number: nothing to chart";
    }
    box.addEventListener("change", () => {
      chart.toggle(k, box.checked);
      state.chartNames = chart.picked.map((q) => scene.columns[q].name);
    });
    tr.insertCell().appendChild(box);
    tr.insertCell().textContent = c.name;
    const v = tr.insertCell(); v.className = "value";
    state.rows.push({ tr, v, box });
  });
}

// The chart's signals, by name: the student's picks (or ?chart=a,b, or the last two numeric
// signals), kept across Play, Restart and robot switches; a name the new run lacks is skipped.
function pickChart(scene) {
  if (state.chartNames === null) {
    const wanted = new URLSearchParams(location.search).get("chart");
    state.chartNames = wanted ? wanted.split(",") : defaultChart(scene);
  }
  const picks = state.chartNames.map((n) => scene.columns.findIndex((c) => c.name === n))
    .filter((k) => k >= 0 && scene.columns[k].numeric !== false);
  for (const k of picks) state.rows[k].box.checked = true;
  chart.setPicked(picks);
}

// paused on a condition: tick what it reads in the chart, so that its values up to this tick show
function chartHit(hit) {
  const names = new Set(hit.what.match(/[A-Za-z_][A-Za-z0-9_.]*/g) || []);
  const cols = state.scene.columns;
  const add = cols.map((c, k) => k).filter((k) => names.has(cols[k].name) && cols[k].numeric !== false
                                           && state.rows[k] && !state.rows[k].box.checked);
  if (!add.length) return;
  for (const k of add) state.rows[k].box.checked = true;
  chart.setPicked(chart.picked.concat(add));
  state.chartNames = chart.picked.map((k) => cols[k].name);
}

function defaultChart(scene) {
  const skip = scene.mode === "replay" ? ["wheel_left", "wheel_right"] : [];
  return scene.columns.filter((c) => (c.group === "signal" || c.group === "trace") && c.numeric !== false
                              && !skip.includes(c.name)).slice(-2).map((c) => c.name);
}

// -- the run so far: sent before the first frame (a new tab, a reload, a reconnect) and after a
// replay's seek, as the frames up to there would have drawn it; it replaces what was drawn ----
function onHistory(h) {
  if (!state.scene || !state.scene.ok) return;
  listEvents(h.events, h.events_before, true);
  world.setHistory(h.robots.map((r) => r.path), h.robots.map((r) => r.hits), h.robots.map((r) => r.marks));
  chart.setHistory(h.robots.map((r) => r.samples), h.robots.map((r) => r.spans), h.robots.map((r) => r.bands));
  state.history = h;
}

// -- the count metrics (a near miss, as the behaviour defines it: count(min(ahead, ...) < 0.25)):
// each a triangle in its colour where it rose, on the path, and its count, as the map shows them
function buildCounts(scene) {
  const box = $("counts");
  box.textContent = "";
  (scene.counts || []).forEach((name, k) => {
    const column = scene.columns.findIndex((c) => c.name === name && c.group === "metric");
    if (column < 0) return;
    const d = document.createElement("div"), mark = document.createElement("span");
    d.dataset.column = String(column); d.dataset.name = name;
    mark.className = "count-mark"; mark.style.color = LV.EVENT_RGB[k % LV.EVENT_RGB.length]; mark.textContent = "▲";
    const label = document.createElement("span");
    label.className = "muted"; label.textContent = ` ${name} `;
    d.append(mark, label, document.createElement("strong"));
    box.appendChild(d);
  });
}

// -- the run's events, as its trace's events column and more: slider moves, the timeline's,
// changes by hand, count metrics and logs, states entered, collisions begun, breakpoints that
// held; the latest EVENTS listed, newest last. A frame carries its latest few and says how many
// it left out; a history (a new tab, a reload, a reconnect) carries the run's so far ----------
const EVENTS = 300;
function listEvents(events, skipped, reset) {
  const ol = $("events");
  if (reset) { ol.textContent = ""; state.events = 0; }
  const several = state.scene && (state.scene.robots || []).length > 1;
  if (skipped) {
    const li = document.createElement("li");
    li.className = "more";
    li.textContent = reset ? `… ${skipped} earlier (in the trace)` : `… ${skipped} more (in the trace)`;
    ol.appendChild(li);
  }
  for (const e of events || []) {
    const li = document.createElement("li");
    li.textContent = `t = ${Number(e[1]).toFixed(2)} s  ${several ? e[2] + ": " : ""}${e[3]}`;  // text, never HTML
    li.dataset.tick = String(e[0]);
    ol.appendChild(li);
  }
  state.events += (events || []).length + (skipped || 0);
  while (ol.children.length > EVENTS) ol.removeChild(ol.firstChild);
  ol.scrollTop = ol.scrollHeight;
  setText($("events-count"), state.events ? String(state.events) : "");
}

// -- frames ---------------------------------------------------------------------------------
// Every frame is acknowledged once the page has drawn it ({"type": "ack"}): the server sends the
// next one only then, so a page that draws slowly gets fewer frames instead of a queue of them
// and the run never waits for it. A frame with nothing to draw is acknowledged at once.
function onFrame(frame) {
  if (!state.scene || !state.scene.ok) { send({ type: "ack" }); return; }
  state.unacked = true;
  state.frame = frame;
  state.frames += 1;
  world.setFrame(frame);
  if (world.onBlock) blockTools();
  chart.add(frame);
  if (frame.events && frame.events.length) listEvents(frame.events, frame.events_more, false);
  if (frame.hit && (!state.lastHit || state.lastHit !== frame.hit.tick)) chartHit(frame.hit);
  state.lastHit = frame.hit ? frame.hit.tick : null;
  scheduleDraw();
}

let drawPending = false;
function scheduleDraw() {
  if (drawPending) return;
  drawPending = true;
  requestAnimationFrame(() => {
    drawPending = false;
    render();
    if (state.unacked) { state.unacked = false; send({ type: "ack" }); }
  });
}

// A value cell, as a label's {x:.2f} field prints it: two decimals, for every group (sensors,
// signals, sliders, metrics) and a replay's columns alike. Whole numbers (booleans, counts, a
// slider at 5) show as integers, as {x:d} would; a million and over in exponent form so that the
// column stays narrow.
LV.fmt = (v) => {
  if (v === null || v === undefined) return "–";
  if (typeof v === "string") return v;
  if (Number.isInteger(v) && Math.abs(v) < 1e6) return String(v);
  if (Math.abs(v) >= 1e6) return v.toExponential(2);
  // toFixed rounds an exact tie away from zero, Python's format to even (0.125: "0.13" against
  // "0.12"). At two decimals the ties are the odd multiples of 1/8, which 8 * v finds exactly.
  if (Number.isInteger(8 * v) && (8 * v) % 2 !== 0) {
    const n = Math.round(v * 100);  // v * 100 is exact here: k + 0.5, and round goes up
    const even = n % 2 === 0 ? n : n - 1;
    return (even / 100).toFixed(2);
  }
  return v.toFixed(2);
};
const fmt = LV.fmt;

function render() {
  const f = state.frame, scene = state.scene;
  if (!f || !scene) return;
  const t0 = performance.now();
  // every text below is written only when it changes (setText): a write of the same text still
  // replaces the element's text and costs the page a style and layout pass, 20 times a second
  setText($("play"), f.playing ? "Pause" : "Play");
  const ended = f.finished && !f.playing;
  if (state.ended !== ended) { state.ended = ended; enableControls(); endBanner(f); }
  const end = scene.mode === "replay" ? ` / ${scene.end_s.toFixed(2)} s` : (scene.stop_s ? ` / ${scene.stop_s} s` : "");
  // the tick whose pose, values, state and rule the page shows (a live run's last tick run)
  const at = f.ran === 0 ? "not started" : `tick ${f.tick}`;
  setText($("clock"), `t = ${f.time.toFixed(2)} s${end}  (${at})${f.finished ? " — ended" : ""}`);
  setText($("rtf"), f.rtf ? `${f.rtf >= 10 ? f.rtf.toFixed(0) : f.rtf.toFixed(2)}× real time` : "");
  if (document.activeElement !== $("speed")) $("speed").value = String(f.speed);
  if (scene.mode === "replay" && !state.scrubbing) {  // it follows the run, unless held by the pointer
    $("scrubber").value = String(f.tick);
  }
  setText($("scrub-time"), scene.mode === "replay" ? `${f.time.toFixed(2)} s` : "");
  for (const input of $("sliders").querySelectorAll("input")) {
    const n = input.dataset.name, div = input.parentElement;
    // the thumb and its value are the student's until let go, and a moment after a key moved it
    // (a frame built before the move came would put it back, and the next key step from there)
    if (state.dragging === n || performance.now() - (state.touched[n] || -1e9) < TOUCHED_MS) continue;
    if (n in f.sliders) input.value = f.sliders[n];
    setText(div.querySelector(".value"), n in f.sliders ? fmt(f.sliders[n]) : "");
  }
  for (const d of $("slider-labels").children) setText(d, f.labels[d.dataset.label] || "");
  const r = f.robots[state.robot];
  if (r) {
    setText($("state"), r.state || "–");
    setText($("hits"), r.collisions === undefined ? "–" : String(r.collisions));
    for (const d of $("counts").children) setText(d.lastChild, fmt(r.values[Number(d.dataset.column)]));
    const rule = scene.rules.find((q) => q.id === r.rule);
    setText($("rule"), r.rule ? `${r.rule}: ${rule ? rule.text : ""}` : "(none fired)");
    // before the first tick a signal or a metric has no value yet (not 0): a dash, as the chart has none
    const none = f.ran === 0 && scene.mode === "live";
    r.values.forEach((v, k) => {
      const g = scene.columns[k] && scene.columns[k].group;
      if (state.rows[k]) setText(state.rows[k].v, none && (g === "signal" || g === "metric") ? "–" : fmt(v));
    });
  }
  renderBreaks(f);
  if ("edited" in f) setText($("editor-state"), f.edited ? "applied, not saved" : "");
  renderImages(f.images);
  world.selected = state.robot;
  world.draw();
  const t1 = performance.now();
  state.cost.draw += t1 - t0; state.cost.draws += 1;
  // while the run plays the chart keeps to CHART_MS; a paused or ended run's chart is drawn now
  if (!f.playing || t1 - state.chartAt >= CHART_MS) {
    chart.draw();
    state.chartAt = performance.now();
    state.cost.chart += state.chartAt - t1; state.cost.charts += 1;
  } else if (!state.chartLater) {  // the frames may stop coming: the last one still reaches the chart
    state.chartLater = setTimeout(() => { state.chartLater = null; scheduleDraw(); }, CHART_MS);
  }
}

const ENDED_WHY = { "stop condition": "its stop condition held", "max ticks": "it reached its last tick",
                    "budget": "it went over its budget", "interrupted": "it was interrupted" };
function endBanner(f) {  // a finished run says so in words, not only by a greyed button
  if (state.offline) return;
  const b = $("ended"), replay = state.scene.mode === "replay";
  b.hidden = !state.ended;
  if (!state.ended) return;
  b.className = "ended";
  b.textContent = replay ? `End of the trace (t = ${f.time.toFixed(2)} s). Rewind or the scrubber go back.`
    : `The run has ended at t = ${f.time.toFixed(2)} s` + (f.why ? ` (${ENDED_WHY[f.why] || f.why})` : "") +
      ". Restart runs it again.";
}

function setText(el, text) {  // a cell written only when it changes: each write costs a layout
  if (el.textContent !== text) el.textContent = text;
}

// -- the editor: the file in a textarea with line numbers; Apply checks it (its problems at their
// line and column, the old run going on) and restarts with it; Save writes it over the file -----
function editorScene(scene) {
  const live = scene.mode === "live", ro = !!scene.read_only;
  $("edit").hidden = !live;
  $("edit-here").hidden = !live || ro;
  $("read-only").hidden = !(live && ro);
  $("source").readOnly = ro;
  enableControls();
  $("editor-name").textContent = scene.path + (ro ? " (read-only: labsim view --read-only)" : "");
  if (typeof scene.source === "string" && (!state.editing || state.applied)) {
    $("source").value = scene.source;  // a fresh run: its text (the page's own edit, once applied)
    state.applied = false;
    markProblems([]);
  }
  $("editor-state").textContent = scene.edited ? "applied, not saved" : "";
}

function openEditor(open) {
  state.editing = open;
  $("editor-panel").hidden = !open;
  if (open) { $("diagnostics").hidden = true; gutter(); $("source").focus(); }
}

function gutter(bad) {
  const n = $("source").value.split("\n").length, marks = new Set(bad || state.badLines || []);
  $("gutter").textContent = "";
  for (let i = 1; i <= n; i++) {
    const line = document.createElement("div");
    line.textContent = String(i);
    if (marks.has(i)) line.className = "bad";
    $("gutter").appendChild(line);
  }
  $("gutter").scrollTop = $("source").scrollTop;
}

function markProblems(places) {
  const ul = $("problems");
  ul.innerHTML = "";
  state.badLines = places.map((p) => p.line);
  for (const p of places) {
    const li = document.createElement("li");
    li.className = p.severity === "warning" ? "warning" : "error";
    li.textContent = `line ${p.line}, column ${p.col}: ${p.message}`;
    li.addEventListener("click", () => goTo(p.line, p.col));
    ul.appendChild(li);
  }
  gutter();
  if (places.length) goTo(places[0].line, places[0].col);
}

function goTo(line, col) {  // put the caret at a line and column of the text
  const lines = $("source").value.split("\n");
  let at = 0;
  for (let i = 0; i < line - 1 && i < lines.length; i++) at += lines[i].length + 1;
  at += Math.max(0, col - 1);
  $("source").focus();
  $("source").setSelectionRange(at, at + 1);
  $("source").scrollTop = Math.max(0, (line - 4) * 17);
}

function refused(msg) {
  if (state.pendingEdit && msg.places && msg.places.length) {
    state.pendingEdit = false;
    markProblems(msg.places);
    notice("Not applied: the file has errors (the run goes on):", msg.diagnostics.join("\n"), true);
    return;
  }
  state.pendingEdit = false;
  notice("That change was refused:", msg.diagnostics.join("\n"), true);
}

$("edit").addEventListener("click", () => openEditor(!state.editing));
$("edit-here").addEventListener("click", () => openEditor(true));
$("close-editor").addEventListener("click", () => openEditor(false));
$("source").addEventListener("input", () => gutter());
$("source").addEventListener("scroll", () => { $("gutter").scrollTop = $("source").scrollTop; });
$("source").addEventListener("keydown", (e) => {  // Tab indents (two spaces, as YAML wants), not leaves
  if (e.key !== "Tab") return;
  e.preventDefault();
  const t = $("source"), a = t.selectionStart;
  t.setRangeText("  ", a, t.selectionEnd, "end");
  gutter();
});
$("apply").addEventListener("click", () => {
  notice(""); markProblems([]);
  state.pendingEdit = true; state.applied = true;
  send({ type: "apply", text: $("source").value });
});
$("save").addEventListener("click", () => {
  // it replaces the student's file on disk: asked first, as an editor asks before overwriting
  if (!window.confirm(`Save over ${state.scene.path}? The file on disk is replaced by this text.`)) return;
  notice("");
  send({ type: "save", text: $("source").value });
  state.saved = $("source").value;
});

// -- breakpoints: the list (each with its remove button) and the one the run paused on ----------
const BREAK_HINT = { when: "sonar5 < 0.3", state: "any, or a state's name", rule: "a rule's id", time: "12.5" };
function breakHint(scene) {  // a condition on a value this run has: its first numeric sensor, else signal
  const c = scene.columns.find((q) => q.group === "sensor" && q.numeric !== false)
    || scene.columns.find((q) => q.group === "signal" && q.numeric !== false);
  BREAK_HINT.when = c ? `${c.name} < 0.3` : "time > 10";
  $("break-text").placeholder = BREAK_HINT[$("break-kind").value];
}
$("break-kind").addEventListener("change", () => { $("break-text").placeholder = BREAK_HINT[$("break-kind").value]; });
$("break-form").addEventListener("submit", (e) => {
  e.preventDefault();
  const kind = $("break-kind").value, text = $("break-text").value.trim();
  if (kind === "when" && !text) return;
  notice("");
  send({ type: "break", add: kind === "when" ? text : (text ? `${kind}:${text}` : kind) });
  $("break-text").value = "";
});

function renderBreaks(f) {
  const list = f.breakpoints || [], key = JSON.stringify(list);
  if (state.breaksShown !== key) {
    state.breaksShown = key;
    const ul = $("breaks");
    ul.innerHTML = "";
    list.forEach((spec, k) => {
      const li = document.createElement("li");
      const code = document.createElement("code"); code.textContent = spec;
      const x = document.createElement("button");
      x.type = "button"; x.className = "remove"; x.textContent = "×"; x.title = "remove";
      x.addEventListener("click", () => send({ type: "break", remove: k }));
      li.appendChild(code); li.appendChild(x); ul.appendChild(li);
    });
  }
  const hit = f.hit, box = $("break-hit");
  if (box.hidden !== !hit) box.hidden = !hit;
  if (hit) {  // every breakpoint that held on that tick, each with its robot's state and rule then
    const many = state.scene.robots.length > 1;
    const parts = (hit.fired || [{ what: [hit.what], robot: hit.robot, state: hit.state, rule: hit.rule }]).map((f) => {
      const rule = f.rule ? state.scene.rules.find((q) => q.id === f.rule) : null;
      return f.what.join(" and ") + (many ? ` (${f.robot})` : "") + ` — state ${f.state || "–"}, rule ` +
        (f.rule ? `${f.rule}: ${rule ? rule.text : ""}` : "(none fired)");
    });
    setText(box, `Paused on tick ${hit.tick} (t = ${hit.time.toFixed(2)} s): ${parts.join("; ")}. ` +
                 "Step goes on one tick, Play runs on.");
  }
}

function renderImages(images) {
  const box = $("images");
  const want = images ? [["camera", images.camera]].concat(images.derived || []).filter(([, url]) => url) : [];
  if (box.children.length !== want.length) {
    box.innerHTML = "";
    for (const [name] of want) {
      const fig = document.createElement("figure");
      fig.innerHTML = "<img alt=''><figcaption></figcaption>";
      fig.querySelector("figcaption").textContent = name;
      fig.querySelector("img").alt = name;
      box.appendChild(fig);
    }
  }
  want.forEach(([name, url], i) => {
    const fig = box.children[i];
    setText(fig.querySelector("figcaption"), name);
    const img = fig.querySelector("img");
    if (img.src !== url) img.src = url;
  });
}

function selectRobot(i) {
  state.robot = i;
  $("robot").value = String(i);
  send({ type: "select", robot: i });
  chart.select(i);
  scheduleDraw();
}

// -- controls ---------------------------------------------------------------------------------
$("play").addEventListener("click", () => send({ type: state.frame && state.frame.playing ? "pause" : "play" }));
$("step").addEventListener("click", () => send({ type: "step" }));
$("restart").addEventListener("click", () => send({ type: "restart" }));
$("speed").addEventListener("change", () => {
  const v = $("speed").value;
  send({ type: "speed", value: v === "max" ? "max" : Number(v) });
  $("speed").blur();
});
$("robot").addEventListener("change", () => selectRobot(Number($("robot").value)));
$("timeline").addEventListener("change", () => send({ type: "timeline", on: $("timeline").checked }));
$("recheck").addEventListener("click", () => send({ type: "recheck" }));
$("scrubber").addEventListener("input", () => send({ type: "seek", tick: Number($("scrubber").value) }));
$("scrubber").addEventListener("pointerdown", () => { state.scrubbing = true; });
$("scrubber").addEventListener("pointerup", () => { state.scrubbing = false; });
document.addEventListener("keydown", (e) => {
  if (["INPUT", "SELECT", "TEXTAREA"].includes(e.target.tagName)) return;
  if (e.key === " ") { e.preventDefault(); $("play").click(); }
  else if (e.key === ".") send({ type: "step" });
});

// the server's messages (docs/view.md, "Messages"), one handler each
const HANDLERS = { scene: onScene, history: onHistory, frame: onFrame, error: refused };

connect();
