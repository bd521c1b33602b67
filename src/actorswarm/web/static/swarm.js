// The swarm panel: who is there (joined, left, never heard; last heard), the master and
// epoch, each platform's actors with their control block's status and statistics, what its
// vehicle says of itself (link, autopilot and mode, arming, battery — in red when the link
// is lost; the column shows only when some vehicle says anything), and — for the platform
// picked on the map or in the table — every control block in full. Without a pick, the
// side shows when platforms joined and left.

import { actorColour, chip, clock, el } from "./util.js";

// A kept actor's control block says "sleeping"; the page and the docs call it paused.
function said(status) {
  return status === "sleeping" ? "paused" : status;
}

function seconds(s) {
  return s == null ? "—" : s < 10 ? `${s.toFixed(1)} s` : `${Math.round(s)} s`;
}

/** Where the actor stands in the firing that switched it in: index, barrier key, slot. */
function group(ctx) {
  if (!ctx.index && ctx.group_key == null) return "—";
  const parts = [`#${ctx.index} of ${ctx.size}`];
  if (ctx.group_key != null) parts.push(`key ${ctx.group_key} gen ${ctx.generation}`);
  if (ctx.slots) parts.push(`slot ${ctx.slot} of ${ctx.slots}`);
  return parts.join(", ");
}

export class SwarmPanel {
  constructor({ tbody, summary, head, body, close, onSelect }) {
    this.tbody = tbody;
    this.summary = summary;
    this.head = head;
    this.body = body;
    this.close = close;
    this.onSelect = onSelect;
    this.selected = null;
    this.last = null;
    this.names = [];
    this.t0 = 0;
    tbody.addEventListener("click", (e) => {
      const row = e.target.closest("tr[data-platform]");
      if (row) this.onSelect(Number(row.dataset.platform));
    });
    close.addEventListener("click", () => this.onSelect(null));
  }

  update(swarm, names, t0) {
    this.last = swarm;
    this.names = names;
    this.t0 = t0;
    const members = swarm.members;
    const joined = members.filter((m) => m.state === "joined").length;
    const left = members.filter((m) => m.state === "left").length;
    const unheard = members.filter((m) => m.state === "unheard").length;
    const masters = swarm.masters.length > 1 ? ` · ${swarm.masters.length} masters (partition?)` : "";
    const alarms = members.filter((m) => m.vehicle_alarm).length;
    this.summary.replaceChildren(
      `${joined} joined · ${left} left` + (unheard ? ` · ${unheard} never heard` : "") + masters,
      alarms ? el("span", { class: "vehicle-alarms" }, ` · ${alarms} vehicle${alarms > 1 ? "s" : ""} not answering`) : "",
    );
    const rows = members.map((m) => this.row(m));
    this.tbody.replaceChildren(...rows);
    this.tbody.closest("table").classList.toggle("no-vehicles", !members.some((m) => m.vehicle));
    if (this.selected == null) this.showLog(swarm.log);
  }

  row(m) {
    const running = m.actors.filter((a) => a.status === "running");
    const switches = m.actors.reduce((n, a) => n + a.switches, 0);
    const time = running.length ? running[0].running_s : null;
    // Running actors in full; the paused ones a switch leaves behind, as a count.
    const pill = (a) =>
      el(
        "span",
        {
          class: `apill ${a.status}${a.errors ? " error" : ""}`,
          title: `${a.name}: ${said(a.status)}` + (a.steps == null ? "" : `, ${a.steps} steps`),
        },
        el("i", { style: `background:${actorColour(this.names, a.name)}` }),
        a.status === "running" ? a.name : `${a.name} (${said(a.status)})`,
      );
    const resting = m.actors.filter((a) => a.status !== "running");
    const actors = running.length ? running.map(pill) : resting.slice(0, 1).map(pill);
    const more = running.length ? resting : resting.slice(1);
    if (more.length) {
      actors.push(el("span", { class: "muted", title: more.map((a) => `${a.name}: ${said(a.status)}`).join("\n") }, `+${more.length} ${more.every((a) => a.status === "sleeping") ? "paused" : "loaded"}`));
    }
    if (!actors.length) actors.push("—");
    if (m.roles && m.roles.length) {
      actors.push(el("span", { class: "muted roles", title: "roles held" }, `roles: ${m.roles.join(", ")}`));
    }
    return el(
      "tr",
      {
        dataset: { platform: m.id, state: m.state },
        class: [m.state === "left" ? "left" : "", m.id === this.selected ? "selected" : ""].join(" "),
      },
      el("td", {}, el("span", { class: "pid" }, m.id), m.master ? el("span", { class: "crown", title: "master" }, "★") : null),
      el("td", {}, el("span", { class: `state-pill ${m.state}` }, m.state)),
      el("td", {}, ...actors),
      el("td", { class: "num" }, switches),
      el("td", { class: "num" }, time == null ? "—" : seconds(time)),
      el("td", { class: "num" }, seconds(m.heard)),
      el("td", { class: "num" }, m.epoch ?? "—"),
      el("td", { class: "num" }, m.inc ?? "—"),
      el("td", { class: "num", title: m.script || "" }, m.script ? m.script.slice(0, 8) : "—"),
      el("td", { class: m.vehicle_alarm ? "vehicle alarm" : "vehicle", title: m.vehicle || "" }, m.vehicle || "—"),
    );
  }

  select(id) {
    this.selected = id;
    for (const row of this.tbody.querySelectorAll("tr")) {
      row.classList.toggle("selected", Number(row.dataset.platform) === id);
    }
    this.close.hidden = id == null;
    if (id == null) {
      this.head.textContent = "Membership";
      if (this.last) this.showLog(this.last.log);
    } else {
      this.head.textContent = `Platform ${id}`;
      this.body.replaceChildren(el("p", { class: "muted" }, "asking…"));
    }
  }

  showLog(log) {
    this.head.textContent = "Membership";
    const items = [...log].reverse().map((e) =>
      el("li", {}, `${clock(e.t - this.t0).padStart(8)}  platform ${e.platform} `, el("span", { class: e.what }, e.what)),
    );
    this.body.replaceChildren(items.length ? el("ul", { class: "mlog" }, ...items) : el("p", { class: "muted" }, "no change yet"));
  }

  /** An `acb` message: every control block of the selected platform. */
  showAcbs(message) {
    if (message.platform !== this.selected) return;
    const acbs = message.acbs;
    if (!acbs || !Object.keys(acbs).length) {
      this.body.replaceChildren(el("p", { class: "muted" }, acbs ? "no actor loaded" : "no status from this platform yet"));
      return;
    }
    const order = (a) => (a.status === "running" ? 0 : 1);
    const blocks = Object.values(acbs).sort((a, b) => order(a) - order(b));
    // A replay's blocks are rebuilt from the transitions: say so once, above them.
    const note = blocks.some((a) => a.recorded)
      ? [el("p", { class: "muted" }, "from the recorded transitions (a recording holds no control blocks):")]
      : [];
    this.body.replaceChildren(...note, ...blocks.map((acb) => this.acb(acb)));
  }

  acb(a) {
    if (a.recorded) return this.recordedAcb(a);
    const s = a.stats || {};
    const ctx = a.context || {};
    const rel = a.relations || {};
    const plugins = (a.software || []).map((p) => `${p.bus.replace("_bus", "")}: ${p.plugin}`).join(", ");
    const params = Object.entries(ctx.params || {}).map(([k, v]) => `${k}=${v}`).join(", ");
    const steps = Object.entries(s.plugins || {})
      .map(([name, p]) => `${name} ${(p.mean * 1000).toFixed(3)} ms mean, ${(p.max * 1000).toFixed(3)} max`)
      .join("; ");
    const rows = [
      ["status", `${said(a.status)} (ID ${a.actor_id}, priority ${a.priority}, ${a.permission})`],
      ["plugins", plugins || "—"],
      ["hardware", (a.hardware || []).join(", ") || "—"],
      ["params", params || "—"],
      ["group", group(ctx)],
      ["came by", rel.transition ? `${rel.transition} from ${rel.predecessor || "—"}` : "—"],
      ["running", `${(s.time_running || 0).toFixed(1)} s, ${s.steps || 0} steps`],
      ["operations", `${s.switch_count || 0} switches, ${s.start_count || 0} starts, ${s.pause_count || 0} pauses, ${s.activate_count || 0} activations`],
      ["step time", steps || "—"],
      ["errors", `${s.error_count || 0}` + (a.last_error ? ` — ${a.last_error}` : "")],
    ];
    return el(
      "div",
      { class: "acb" },
      el("h4", {}, chip(this.names, a.name), said(a.status)),
      el("dl", {}, ...rows.flatMap(([k, v]) => [el("dt", {}, k), el("dd", {}, v)])),
    );
  }

  /** An actor of a replay: what its transitions tell, no more (a recording holds no
   *  control blocks). */
  recordedAcb(a) {
    const s = a.stats || {};
    const rows = [
      ["switches", `${s.switch_count || 0}`],
      ["running", `${(s.time_running || 0).toFixed(1)} s`],
    ];
    return el(
      "div",
      { class: "acb" },
      el("h4", {}, chip(this.names, a.name), said(a.status)),
      el("dl", {}, ...rows.flatMap(([k, v]) => [el("dt", {}, k), el("dd", {}, v)])),
    );
  }
}
