// The timeline of collective transitions, newest first: when, on which event, which
// barrier group, from which actor to which, who took part, and how long the switch took
// from the first participant to the last. A step can still grow after it first shows
// (a retransmitted release reaches a platform late), so steps are kept by id and redrawn.

import { chip, clock, el, idRanges } from "./util.js";

const SHOWN = 300;

export class Timeline {
  constructor(list, count) {
    this.list = list;
    this.count = count;
    this.steps = new Map();
    this.names = [];
    this.t0 = 0;
  }

  reset(steps, names, t0) {
    this.steps.clear();
    this.names = names;
    this.t0 = t0;
    this.list.replaceChildren();
    for (const s of steps) this.put(s, false);
  }

  setNames(names) {
    this.names = names;
  }

  /** Add or replace a step; `fresh` makes it flash. */
  put(step, fresh = true) {
    const old = this.steps.get(step.id);
    const item = this.item(step, fresh && !old);
    if (old) old.item.replaceWith(item);
    else this.list.prepend(item);
    this.steps.set(step.id, { step, item });
    while (this.list.children.length > SHOWN) this.list.lastElementChild.remove();
    this.count.textContent = `(${this.steps.size})`;
  }

  item(s, fresh) {
    const n = s.platforms.length;
    const cause = s.cause === "barrier" ? null : el("span", { class: `badge ${s.cause}` }, s.cause);
    const group = s.key == null ? null : el("span", { class: "badge", title: "barrier group (barrierKey)" }, `key ${s.key}`);
    return el(
      "li",
      {
        class: fresh ? "fresh" : "",
        dataset: { id: s.id, event: s.event, from: s.from, to: s.to, count: n, cause: s.cause },
      },
      el("span", { class: "t" }, clock(s.t - this.t0)),
      el(
        "span",
        { class: "ev" },
        el("span", { class: "name", title: s.event }, s.event || (s.cause === "observed" ? "seen in status" : "—")),
        group,
        cause,
      ),
      el("span", { class: "sw", title: "from the first participant's switch to the last's" }, s.cause === "observed" ? "" : `${s.switch_ms.toFixed(0)} ms`),
      el(
        "span",
        { class: "line" },
        el("span", { class: "move" }, chip(this.names, s.from), " → ", chip(this.names, s.to)),
        el("span", { class: "who", title: idRanges(s.platforms) }, `${n} platform${n === 1 ? "" : "s"}: ${idRanges(s.platforms)}`),
      ),
    );
  }
}
