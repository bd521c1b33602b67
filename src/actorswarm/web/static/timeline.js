// The timeline of collective transitions, newest first: when, on which event, which
// barrier group, from which actor to which, who took part, and how long the switch took
// from the first participant to the last. A step can still grow after it first shows
// (a retransmitted release reaches a platform late), so steps are kept by id and redrawn.
// A replayed recording's operator commands (cause "command") are rows of their own: the
// platforms' answer and who gave it.

import { chip, clock, el, idRanges } from "./util.js";

const SHOWN = 300;

// A collective transition that branches (one event sending some platforms to B and the
// others to C) is several steps, one per destination: they are shown as one row with a
// part per destination, as the operator thinks of them.
const WINDOW = 1.0;

export class Timeline {
  constructor(list, count) {
    this.list = list;
    this.count = count;
    this.steps = new Map(); // step id -> row
    this.rows = [];
    this.names = [];
    this.t0 = 0;
  }

  reset(steps, names, t0) {
    this.steps.clear();
    this.rows = [];
    this.names = names;
    this.t0 = t0;
    this.list.replaceChildren();
    this.count.textContent = "(0)"; // a replay sought back to before its first step has none
    for (const s of steps) this.put(s, false);
  }

  setNames(names) {
    this.names = names;
  }

  /** The row `step` belongs to: its own, or that of a step of the same transition
   * (same event, source and cause, within the window) to another destination. */
  rowFor(step) {
    const known = this.steps.get(step.id);
    if (known) return known;
    for (let i = this.rows.length - 1; i >= 0 && i >= this.rows.length - 20; i--) {
      const row = this.rows[i];
      const first = row.parts.values().next().value;
      if (
        first.event === step.event && first.from === step.from && first.cause === step.cause &&
        (step.event || step.cause === "observed") && Math.abs(step.t - first.t) <= WINDOW &&
        ![...row.parts.values()].some((p) => p.to === step.to)
      ) return row;
    }
    const row = { id: step.id, parts: new Map(), item: null };
    this.rows.push(row);
    return row;
  }

  /** Add or replace a step; `fresh` makes its row flash. */
  put(step, fresh = true) {
    const row = this.rowFor(step);
    const isNew = !this.steps.has(step.id);
    row.parts.set(step.id, step);
    this.steps.set(step.id, row);
    const item = this.item([...row.parts.values()], fresh && isNew);
    if (row.item) row.item.replaceWith(item);
    else this.list.prepend(item);
    row.item = item;
    while (this.list.children.length > SHOWN) {
      this.list.lastElementChild.remove();
      const gone = this.rows.shift();
      for (const id of gone.parts.keys()) this.steps.delete(id);
    }
    this.count.textContent = `(${this.rows.length})`;
  }

  /** An operator's command seen in a recording: the answer, and who answered so. */
  command(s, fresh) {
    const k = s.platforms.length;
    const failed = s.event.includes(" FAILED: ");
    return el(
      "li",
      { class: `command${fresh ? " fresh" : ""}`, dataset: { id: s.id, event: s.event, count: k, cause: s.cause, parts: 1 } },
      el("span", { class: "t" }, clock(s.t - this.t0)),
      el("span", { class: "ev" }, el("span", { class: `name${failed ? " failed" : ""}`, title: s.event }, s.event), el("span", { class: "badge command" }, "command")),
      el("span", { class: "sw" }, ""),
      el("span", { class: "line" }, el("span", { class: "who", title: idRanges(s.platforms) }, `answered by ${k} platform${k === 1 ? "" : "s"}: ${idRanges(s.platforms)}`)),
    );
  }

  item(parts, fresh) {
    const s = parts[0];
    if (s.cause === "command") return this.command(s, fresh);
    const n = parts.reduce((sum, p) => sum + p.platforms.length, 0);
    const t = Math.min(...parts.map((p) => p.t));
    const ms = Math.max(...parts.map((p) => p.t_last)) - t;
    const cause = s.cause === "barrier" ? null : el("span", { class: `badge ${s.cause}` }, s.cause);
    const group = s.key == null ? null : el("span", { class: "badge", title: "barrier group (barrierKey)" }, `key ${s.key}`);
    return el(
      "li",
      {
        class: fresh ? "fresh" : "",
        dataset: { id: s.id, event: s.event, from: s.from, to: parts.map((p) => p.to).join(" "), count: n, cause: s.cause, parts: parts.length },
      },
      el("span", { class: "t", style: `grid-row: span ${parts.length + 1}` }, clock(t - this.t0)),
      el(
        "span",
        { class: "ev" },
        el("span", { class: "name", title: s.event }, s.event || (s.cause === "observed" ? "seen in status" : "—")),
        group,
        cause,
      ),
      el("span", { class: "sw", title: "from the first participant's switch to the last's" }, s.cause === "observed" ? "" : `${(ms * 1000).toFixed(0)} ms`),
      ...parts.map((p) => {
        const k = p.platforms.length;
        return el(
          "span",
          { class: "line part", dataset: { to: p.to, count: k } },
          el("span", { class: "move" }, chip(this.names, p.from), " → ", chip(this.names, p.to)),
          el("span", { class: "who", title: idRanges(p.platforms) }, `${k} platform${k === 1 ? "" : "s"}: ${idRanges(p.platforms)}`),
        );
      }),
    );
  }
}
