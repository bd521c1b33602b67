// The operator's controls and the command log. Every form becomes one request to the
// server; every request's outcome — pending while platforms answer, then done — shows in
// the log with each platform's answer. A script's problems are listed with their line and
// column; a deployment shows each platform's confirmation as it arrives.

import { clock, el } from "./util.js";

const $ = (id) => document.getElementById(id);

function ids(input) {
  const text = input.value.trim();
  return text ? text : null;
}

function options(select, values, first) {
  const keep = select.value;
  select.replaceChildren(...(first ? [el("option", { value: "" }, first)] : []), ...values.map((v) => el("option", { value: v }, v)));
  if ([...select.options].some((o) => o.value === keep)) select.value = keep;
}

export class Controls {
  constructor(link) {
    this.link = link;
    this.log = $("log");
    this.items = new Map();
    this.t0 = 0;
    this.scriptName = "uploaded.xml";
    this.watching = null; // the id of this page's latest check or deploy

    for (const button of document.querySelectorAll(".tabs button")) {
      button.addEventListener("click", () => this.tab(button.dataset.tab));
    }
    $("tab-event").addEventListener("submit", (e) => {
      e.preventDefault();
      const actors = [...$("event-actors").querySelectorAll("input:checked")].map((i) => i.value);
      this.send({ op: "event", name: $("event-name").value.trim(), platforms: ids($("event-platforms")), actors });
    });
    $("tab-force").addEventListener("submit", (e) => {
      e.preventDefault();
      const params = {};
      for (const line of $("force-params").value.split("\n")) {
        const at = line.indexOf("=");
        if (at > 0) params[line.slice(0, at).trim()] = line.slice(at + 1).trim();
      }
      this.send({ op: "force", to: $("force-to").value, src: $("force-from").value || null, platforms: ids($("force-platforms")), params });
    });
    for (const button of document.querySelectorAll("[data-actor-op]")) {
      button.addEventListener("click", () =>
        this.send({ op: button.dataset.actorOp, actor: $("actor-name").value, platforms: ids($("actor-platforms")) }),
      );
    }
    $("tab-actor").addEventListener("submit", (e) => e.preventDefault());
    $("tab-script").addEventListener("submit", (e) => e.preventDefault());
    $("script-file").addEventListener("change", async (e) => {
      const file = e.target.files[0];
      if (!file) return;
      this.scriptName = file.name;
      $("script-text").value = await file.text();
      this.script("check");
    });
    $("script-text").addEventListener("input", () => {
      if (!$("script-file").files.length) this.scriptName = "pasted.xml";
    });
    $("script-check").addEventListener("click", () => this.script("check"));
    $("script-deploy").addEventListener("click", () => this.script("deploy"));
    $("script-start").addEventListener("click", () => this.send({ op: "start", force: $("start-force").checked }));
    $("tab-backup").addEventListener("submit", (e) => {
      e.preventDefault();
      this.send({ op: "backup", platforms: ids($("backup-platforms")) });
    });
    $("speed").addEventListener("change", (e) => this.send({ op: "speed", speed: Number(e.target.value) }));
  }

  tab(name) {
    for (const b of document.querySelectorAll(".tabs button")) b.classList.toggle("on", b.dataset.tab === name);
    for (const f of document.querySelectorAll(".tab")) f.classList.toggle("on", f.id === `tab-${name}`);
  }

  send(request) {
    return this.link.send(request);
  }

  script(op) {
    const text = $("script-text").value;
    if (!text.trim()) {
      $("script-errors").replaceChildren(el("li", {}, "choose a task script file, or paste one"));
      return;
    }
    const request = { op, script: text, name: this.scriptName };
    if (op === "deploy") request.platforms = ids($("deploy-platforms"));
    this.watching = this.send(request);
    $("script-errors").replaceChildren(el("li", { class: "warning" }, op === "check" ? "checking…" : "checking and deploying…"));
    $("confirmations").replaceChildren();
  }

  /** The running script changed: offer its events and actors. */
  setScript(script) {
    const actors = script ? script.actors : [];
    $("event-list").replaceChildren(...(script ? script.events : []).map((e) => el("option", { value: e })));
    $("event-actors").replaceChildren(
      ...actors.map((a) => el("label", {}, el("input", { type: "checkbox", value: a }), a)),
    );
    if (!actors.length) $("event-actors").append("—");
    options($("force-from"), actors, "any actor");
    options($("force-to"), actors);
    options($("actor-name"), actors);
  }

  reset(outcomes, t0) {
    this.t0 = t0;
    this.items.clear();
    this.log.replaceChildren();
    for (const o of outcomes) this.outcome(o);
  }

  outcome(o) {
    const state = o.state === "pending" ? "…" : o.ok ? "✓" : "✗";
    const answers = Object.entries(o.answers || {});
    const item = el(
      "li",
      { dataset: { id: o.id, op: o.op, state: o.state, ok: String(o.ok) } },
      el(
        "div",
        { class: "head" },
        el("span", { class: "state" }, state),
        el("span", { class: "asked", title: o.asked }, o.asked || o.op),
        el("span", { class: "t" }, o.t == null ? "" : clock(o.t - this.t0)),
      ),
      o.message ? el("div", { class: "message" }, o.message) : null,
      answers.length
        ? el(
            "details",
            {},
            el("summary", {}, `${answers.length} of ${o.targets.length} platforms answered`),
            ...answers.map(([p, a]) => el("div", {}, `${p}: ${a.ok ? "" : "FAILED: "}${a.message}`)),
          )
        : null,
    );
    const old = this.items.get(o.id);
    if (old && old.isConnected && o.id) old.replaceWith(item);
    else this.log.prepend(item);
    if (o.id) this.items.set(o.id, item);
    while (this.log.children.length > 100) this.log.lastElementChild.remove();
    if (o.id && o.id === this.watching) this.scriptOutcome(o);
  }

  /** What the page's latest check or deployment says about the script. */
  scriptOutcome(o) {
    const list = $("script-errors");
    if (o.diagnostics.length) {
      list.replaceChildren(
        ...o.diagnostics.map((d) =>
          el(
            "li",
            { class: d.severity, dataset: { line: d.line, col: d.col } },
            el("span", { class: "pos" }, `line ${d.line}, column ${d.col}`),
            `: ${d.severity === "warning" ? "warning: " : ""}${d.message}`,
          ),
        ),
      );
    } else if (o.state === "done" && o.op === "check") {
      list.replaceChildren(el("li", { class: "warning", style: "border-color:#5fd68a" }, o.message));
    } else if (o.op === "deploy") {
      list.replaceChildren();
    }
    if (o.op === "deploy" && o.targets.length) {
      $("confirmations").replaceChildren(
        ...o.targets.map((p) => {
          const a = o.answers[String(p)];
          return el("span", { class: a ? (a.ok ? "ok" : "bad") : "", title: a ? a.message : "waiting" }, p);
        }),
      );
    }
  }
}
