// labsim view: where the robots' name labels go on the canvas, so that no two overlap. Robots
// that stand close (the road lab's five at spawn) would otherwise print their names on top of
// each other. Pure geometry in CSS pixels, no drawing: canvas.js draws what this returns, and
// the browser tests call it directly.
"use strict";
window.LV = window.LV || {};

// Places around the robot, in the order tried: up-right first (where a single label has always
// gone), then the other corners, then the sides. Each is [dx, dy]: -1 the box ends before the
// robot, 0 the box is centred on it, 1 the box starts after it.
const LABEL_PLACES = [[1, -1], [1, 1], [-1, -1], [-1, 1], [1, 0], [-1, 0], [0, -1], [0, 1]];
const LABEL_RINGS = 8;  // how far out a label may go, in label heights, before it is stacked
const LABEL_GAP = 2;  // px between a label and its neighbours

LV.boxesMeet = (a, b) => a.x < b.x + b.w && b.x < a.x + a.w && a.y < b.y + b.h && b.y < a.y + a.h;

LV.layoutLabels = (anchors, sizes, view, order) => {
  // anchors: each robot's [x, y] on the canvas (or null: not drawn); sizes: each label's [w, h];
  // view: {width, height, marker}, marker the half-size of a drawn robot; order: the robots by
  // priority (the picked robot first, so its label stays next to it). Returns per robot
  // {x, y, w, h, leader} (top-left corner; leader: null, or the box's point to draw a line to
  // from the robot when the label stands away from it) or null. No two boxes returned meet,
  // whatever the anchors: the last resort stacks a label under all the others.
  const m = view.marker || 8, out = anchors.map(() => null), placed = [];
  const markers = anchors.map((a) => a && { x: a[0] - m, y: a[1] - m, w: 2 * m, h: 2 * m });
  const outside = (b) => b.x < 0 || b.y < 0 || b.x + b.w > view.width || b.y + b.h > view.height;
  const free = (b) => !placed.some((p) => LV.boxesMeet(grow(b), p));
  const grow = (b) => ({ x: b.x - LABEL_GAP, y: b.y - LABEL_GAP, w: b.w + 2 * LABEL_GAP, h: b.h + 2 * LABEL_GAP });
  for (const i of order || anchors.map((_, k) => k)) {
    const a = anchors[i];
    if (!a || !sizes[i]) continue;
    const [w, h] = sizes[i];
    // the robots to keep clear of: not those under this one's own marker, hidden by it anyway
    const others = markers.filter((q, k) => q && k !== i && Math.hypot(anchors[k][0] - a[0], anchors[k][1] - a[1]) > m);
    let best = null, bestCost = Infinity;
    for (let ring = 0; ring < LABEL_RINGS && bestCost > 0; ring++) {
      const d = m - 2 + ring * (h + LABEL_GAP);  // ring 0 touches the robot's marker
      for (const [dx, dy] of LABEL_PLACES) {
        const b = { w, h, x: dx > 0 ? a[0] + d : dx < 0 ? a[0] - d - w : a[0] - w / 2,
                    y: dy > 0 ? a[1] + d : dy < 0 ? a[1] - d - h : a[1] - h / 2 };
        if (!free(b)) continue;
        // over another robot or off the canvas is allowed, but any clean place is better
        const cost = others.some((q) => LV.boxesMeet(b, q)) + 2 * outside(b);
        if (cost < bestCost) { best = b; bestCost = cost; }
        if (cost === 0) break;
      }
    }
    if (!best) {  // crowded beyond the rings: under every label placed so far
      const bottom = Math.max(...placed.map((p) => p.y + p.h));
      best = { w, h, x: a[0] + m, y: bottom + 2 * LABEL_GAP };
    }
    // a label that does not touch its robot's marker gets a line to it, from its nearest point
    const nx = Math.min(Math.max(a[0], best.x), best.x + best.w), ny = Math.min(Math.max(a[1], best.y), best.y + best.h);
    out[i] = { ...best, leader: Math.hypot(nx - a[0], ny - a[1]) > 1.5 * m ? [nx, ny] : null };
    placed.push(best);
  }
  return out;
};
