// The Actor state machine of the running script, drawn from the server's layout (the
// edges of `actorswarm task graph`), with the number of platforms in each actor now and
// the edges of the latest collective transitions lit up for a moment.
//
// The layout (boxes, edge points, label boxes) comes from the server; this draws it. A
// timeout edge that goes where its transition's own edge goes is folded into that edge
// (its tooltip gains the timeout) rather than drawn twice.

import { colour } from "./util.js";

const SVG = "http://www.w3.org/2000/svg";

function svg(tag, attrs = {}, text) {
  const node = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attrs)) node.setAttribute(k, v);
  if (text != null) node.textContent = text;
  return node;
}

export class StateGraph {
  constructor(root) {
    this.root = root;
    this.nodes = new Map();
    this.edges = [];
    this.names = [];
  }

  /** Draw `script` (the hello message's; null: nothing is running). */
  show(script) {
    const root = this.root;
    root.replaceChildren();
    this.nodes.clear();
    this.edges = [];
    this.names = script ? script.actors : [];
    if (!script) {
      root.setAttribute("viewBox", "0 0 300 60");
      root.append(svg("text", { x: 150, y: 34, "text-anchor": "middle", class: "elabel" }, "no script running"));
      return;
    }
    const g = script.graph;
    root.setAttribute("viewBox", `0 0 ${g.width} ${g.height}`);
    const defs = svg("defs");
    for (const [id, fill] of [["arrow", "#5a6b7c"], ["arrow-fired", "#ffd166"]]) {
      const marker = svg("marker", {
        id, viewBox: "0 0 10 10", refX: 9, refY: 5, markerWidth: 7, markerHeight: 7, orient: "auto-start-reverse",
      });
      marker.append(svg("path", { d: "M0,0 L10,5 L0,10 z", fill }));
      defs.append(marker);
    }
    root.append(defs);
    const edgeLayer = svg("g");
    const labelLayer = svg("g");
    const nodeLayer = svg("g");
    root.append(edgeLayer, nodeLayer, labelLayer);

    // The server laid everything out (graph_layout.py): each edge's points and its
    // label's box, placed so that no label covers another or an actor.
    for (const e of g.edges) {
      const path = svg("path", {
        d: this.curve(e), class: `edge ${e.kind}`, "marker-end": "url(#arrow)", "data-source": e.source,
        "data-target": e.target, "data-event": e.event,
      });
      path.append(svg("title", {}, e.title));
      edgeLayer.append(path);
      this.edges.push(path);
      if (e.text && e.box) {
        const b = e.box;
        const label = svg("text", { x: b.x + 3, y: b.y + b.h - 4, class: `elabel ${e.kind}`, "data-source": e.source, "data-target": e.target }, e.text);
        label.append(svg("title", {}, e.title));
        labelLayer.append(label);
        this.fit(label, b.w - 4);
      }
    }
    for (const n of g.nodes) {
      const c = colour(this.names.indexOf(n.name));
      const group = svg("g", { class: "node empty", "data-actor": n.name });
      group.append(svg("rect", {
        x: n.x, y: n.y, width: n.w, height: n.h, rx: 6, fill: `${c}26`, stroke: c,
      }));
      const name = svg("text", { x: n.x + 9, y: n.y + n.h / 2 + 4, class: "name" }, n.name);
      const pill = svg("rect", { x: n.x + n.w - 24, y: n.y + n.h / 2 - 9, width: 20, height: 18, rx: 9, class: "count-bg", fill: c });
      const count = svg("text", { x: n.x + n.w - 14, y: n.y + n.h / 2 + 4, "text-anchor": "middle", class: "count" }, "0");
      group.append(name, pill, count);
      if (n.initial) {
        const x = n.x + n.w / 2;
        nodeLayer.append(svg("circle", { cx: x - 30, cy: n.y - 14, r: 3.5, class: "start" }));
        nodeLayer.append(svg("path", {
          d: `M${x - 26},${n.y - 12} Q${x - 12},${n.y - 12} ${x - 4},${n.y - 1}`, class: "edge", "marker-end": "url(#arrow)",
        }));
        nodeLayer.append(svg("text", { x: x + 2, y: n.y - 8, class: "slabel" }, `platforms ${n.initial}`));
      }
      nodeLayer.append(group);
      // The name whole: a font wider than the layout's estimate is squeezed, never cut.
      this.fit(name, n.w - 9 - 30);
      this.nodes.set(n.name, { group, count, pill, name, right: n.x + n.w - 4 });
    }
    // The start marks may reach past the layout's right edge: show all that was drawn.
    const box = root.getBBox();
    const x0 = Math.min(0, box.x - 2), y0 = Math.min(0, box.y - 2);
    root.setAttribute("viewBox", `${x0} ${y0} ${Math.max(g.width, box.x + box.width + 2) - x0} ${Math.max(g.height, box.y + box.height + 2) - y0}`);
  }

  /** Squeeze `text` into `width` when its font draws it wider. */
  fit(text, width) {
    if (text.getComputedTextLength() > width) {
      text.setAttribute("textLength", String(width));
      text.setAttribute("lengthAdjust", "spacingAndGlyphs");
    }
  }

  /** An edge's path through its points: smooth, vertical where it meets a rank. */
  curve(e) {
    const p = e.points;
    if (e.source === e.target) {
      // A loop on the actor's right.
      const [a, m, b] = p;
      const out = m[0] + 8;
      return `M${a[0]},${a[1]} C${out},${a[1] - 10} ${out},${b[1] + 10} ${b[0] + 2},${b[1]}`;
    }
    let d = `M${p[0][0]},${p[0][1]}`;
    for (let i = 1; i < p.length; i++) {
      const [x0, y0] = p[i - 1], [x1, y1] = p[i];
      const my = (y0 + y1) / 2;
      d += ` C${x0},${my} ${x1},${my} ${x1},${y1}`;
    }
    return d;
  }

  /** Platforms per actor now: {A: 3, ...}. */
  counts(counts) {
    for (const [name, { group, count, pill, right }] of this.nodes) {
      const n = counts[name] || 0;
      count.textContent = String(n);
      // The pill grows to the left with the number's digits.
      const width = 12 + 7 * String(n).length;
      pill.setAttribute("width", width);
      pill.setAttribute("x", right - width);
      count.setAttribute("x", right - width / 2);
      group.classList.toggle("empty", n === 0);
      group.dataset.count = String(n);
    }
  }

  /** Light up the edges a step went along. */
  fired(step) {
    for (const path of this.edges) {
      const hit = path.dataset.source === step.from && path.dataset.target === step.to;
      if (!hit) continue;
      path.classList.add("fired");
      path.setAttribute("marker-end", "url(#arrow-fired)");
      clearTimeout(path._timer);
      path._timer = setTimeout(() => {
        path.classList.remove("fired");
        path.setAttribute("marker-end", "url(#arrow)");
      }, 2500);
    }
  }
}
