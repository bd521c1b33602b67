// The Actor state machine of the running script, drawn from the server's layout (the
// edges of `actorswarm task graph`), with the number of platforms in each actor now and
// the edges of the latest collective transitions lit up for a moment.
//
// A timeout edge that goes where its transition's own edge goes is folded into that edge
// (its label gains the timeout) rather than drawn twice.

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
    const byName = new Map(g.nodes.map((n) => [n.name, n]));
    const edgeLayer = svg("g");
    const nodeLayer = svg("g");
    root.append(edgeLayer, nodeLayer);

    // Fold timeouts into the edge they duplicate.
    const branches = g.edges.filter((e) => e.kind !== "timeout");
    const extra = new Map();
    const drawn = [...branches];
    for (const e of g.edges.filter((e) => e.kind === "timeout")) {
      const twin = branches.find((b) => b.source === e.source && b.target === e.target);
      if (twin) extra.set(twin, (extra.get(twin) || []).concat(e.label));
      else drawn.push(e);
    }
    // A transition that branches to several actors is labelled once, under its source.
    const fans = new Map();
    for (const e of drawn) {
      if (e.kind === "branch" && !e.back) {
        const key = `${e.source}\u0000${e.event}`;
        fans.set(key, (fans.get(key) || 0) + 1);
      }
    }
    // Edges between the same two actors (two transitions, or a branch and a timeout) are
    // drawn side by side.
    const pairs = new Map();
    for (const e of drawn) {
      const key = `${e.source}\u0000${e.target}`;
      pairs.set(key, [...(pairs.get(key) || []), e]);
    }
    const labelled = new Set();
    const backs = { left: 0, right: 0 };
    for (const e of drawn) {
      const a = byName.get(e.source), b = byName.get(e.target);
      if (!a || !b) continue;
      const twins = pairs.get(`${e.source}\u0000${e.target}`);
      const spread = twins.length > 1 && !e.back ? (twins.indexOf(e) - (twins.length - 1) / 2) * 16 : 0;
      let { d, lx, ly, anchor } = this.route(a, b, backs, g, spread);
      if (spread) ly += twins.indexOf(e) * 12 - ((twins.length - 1) * 12) / 2;
      const fan = `${e.source}\u0000${e.event}`;
      if (e.kind === "branch" && !e.back && fans.get(fan) > 1) {
        if (labelled.has(fan)) lx = null;
        labelled.add(fan);
        [lx, ly, anchor] = lx == null ? [null, 0, ""] : [a.x + a.w / 2 + 6, a.y + a.h + 13, "start"];
      }
      const title = [e.label, ...(extra.get(e) || [])].join("\n");
      const path = svg("path", {
        d, class: `edge ${e.kind}`, "marker-end": "url(#arrow)", "data-source": e.source,
        "data-target": e.target, "data-event": e.event,
      });
      path.append(svg("title", {}, title));
      edgeLayer.append(path);
      // The event on the arrow; its share of sysNum, key and timeout in the tooltip.
      const text = e.kind === "branch" ? e.event : e.label.split(" (")[0].replace("timeout ", "");
      if (lx != null) {
        const label = svg("text", { x: lx, y: ly, class: `elabel ${e.kind}`, "text-anchor": anchor }, text);
        label.append(svg("title", {}, title));
        edgeLayer.append(label);
      }
      this.edges.push(path);
    }
    for (const n of g.nodes) {
      const c = colour(this.names.indexOf(n.name));
      const group = svg("g", { class: "node empty", "data-actor": n.name });
      group.append(svg("rect", {
        x: n.x, y: n.y, width: n.w, height: n.h, rx: 6, fill: `${c}26`, stroke: c,
      }));
      group.append(svg("text", { x: n.x + 10, y: n.y + n.h / 2 + 4 }, n.name));
      const pill = svg("rect", { x: n.x + n.w - 24, y: n.y + n.h / 2 - 9, width: 20, height: 18, rx: 9, class: "count-bg", fill: c });
      const count = svg("text", { x: n.x + n.w - 14, y: n.y + n.h / 2 + 4, "text-anchor": "middle", class: "count" }, "0");
      group.append(pill, count);
      if (n.initial) {
        const x = n.x + n.w / 2;
        nodeLayer.append(svg("circle", { cx: x - 40, cy: n.y - 14, r: 3.5, class: "start" }));
        nodeLayer.append(svg("path", {
          d: `M${x - 36},${n.y - 12} Q${x - 20},${n.y - 12} ${x - 8},${n.y - 1}`, class: "edge", "marker-end": "url(#arrow)",
        }));
        nodeLayer.append(svg("text", { x: x - 2, y: n.y - 8, class: "slabel" }, `platforms ${n.initial}`));
      }
      nodeLayer.append(group);
      this.nodes.set(n.name, { group, count, pill, right: n.x + n.w - 4 });
    }
  }

  /** The path of an edge from node a to node b, and where its label goes; `backs` counts
   * the edges already routed back up on each side, so each goes further out. */
  route(a, b, backs, g, spread = 0) {
    if (a === b) {
      // A loop on the node's left, where the layout keeps room.
      const x = a.x, y = a.y + a.h / 2;
      return {
        d: `M${x},${y - 7} C${x - 34},${y - 26} ${x - 34},${y + 26} ${x - 1},${y + 7}`,
        lx: x - 30, ly: y + 3, anchor: "end",
      };
    }
    if (b.layer <= a.layer) {
      // Back up: around the side the source is on (the right when it is in line), each
      // further out than the last on that side.
      const left = a.x + a.w / 2 < b.x + b.w / 2 - 1;
      const k = left ? backs.left++ : backs.right++;
      const y1 = a.y + a.h / 2, y2 = b.y + b.h / 2;
      if (left) {
        const x1 = a.x, x2 = b.x;
        const out = Math.max(6, Math.min(x1, x2) - 30 - 16 * k);
        const tip = x1 + 0.75 * (out - x1); // the curve's outermost point
        return {
          d: `M${x1},${y1} C${out},${y1} ${out},${y2} ${x2 - 2},${y2}`,
          lx: tip - 4, ly: (y1 + y2) / 2 + 3, anchor: "end",
        };
      }
      const x1 = a.x + a.w, x2 = b.x + b.w;
      const out = Math.min(g.width - 6, Math.max(x1, x2) + 30 + 16 * k);
      const tip = x1 + 0.75 * (out - x1);
      return {
        d: `M${x1},${y1} C${out},${y1} ${out},${y2} ${x2 + 2},${y2}`,
        lx: tip + 4, ly: (y1 + y2) / 2 + 3, anchor: "start",
      };
    }
    const x1 = a.x + a.w / 2 + spread, y1 = a.y + a.h, x2 = b.x + b.w / 2 + spread, y2 = b.y - 1;
    if (b.layer - a.layer > 1) {
      // Skips layers: bow out to the side it leaves from, clear of the actors between.
      const side = x1 <= x2 ? Math.min(a.x, b.x) - 30 : Math.max(a.x + a.w, b.x + b.w) + 30;
      return {
        d: `M${x1},${y1} C${side},${y1 + 30} ${side},${y2 - 30} ${x2},${y2}`,
        // Outside the bow, clear of the actors it passes.
        lx: side + (x1 <= x2 ? -4 : 4), ly: (y1 + y2) / 2 + 3, anchor: x1 <= x2 ? "end" : "start",
      };
    }
    const my = (y1 + y2) / 2;
    // The label sits beside the curve, on the side it bends towards, so the labels of a
    // fan of edges part instead of piling up in the middle.
    const t = 0.55, u = 1 - t;
    const px = u * u * u * x1 + 3 * u * u * t * x1 + 3 * u * t * t * x2 + t * t * t * x2;
    const py = u * u * u * y1 + 3 * u * u * t * my + 3 * u * t * t * my + t * t * t * y2;
    const left = x2 < x1 - 1;
    return {
      d: `M${x1},${y1} C${x1},${my} ${x2},${my} ${x2},${y2}`,
      lx: px + (left ? -5 : 5), ly: py + 3, anchor: left ? "end" : "start",
    };
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
