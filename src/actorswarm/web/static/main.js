// The web ground station's page: connects to the server and hands each message to the
// part of the page it is for (map, task, swarm, controls). No framework, no build step:
// these ES modules are served as they are.

import { Controls } from "./controls.js";
import { StateGraph } from "./graph.js";
import { SwarmMap } from "./map.js";
import { Link } from "./socket.js";
import { SwarmPanel } from "./swarm.js";
import { Timeline } from "./timeline.js";
import { clock, colour, el } from "./util.js";

const $ = (id) => document.getElementById(id);

const state = { hello: null, names: [], t0: 0, selected: null, legend: "", up: false };

const link = new Link(receive, (up) => {
  state.up = up;
  showLink();
});

// The badge: a replay is not live, however well connected the page is.
function showLink() {
  const up = state.up;
  $("link").className = `link ${up ? "up" : "down"}`;
  $("link").textContent = !up ? "reconnecting…" : state.hello?.kind === "replay" ? "replay" : "live";
}
const map = new SwarmMap($("map"), $("tooltip"), $("map-note"), { onSelect: select });
const graph = new StateGraph($("graph"));
const timeline = new Timeline($("timeline"), $("step-count"));
const controls = new Controls(link);
const swarm = new SwarmPanel({
  tbody: document.querySelector("#swarm-table tbody"),
  summary: $("swarm-summary"),
  head: document.querySelector("#detail-head b"),
  body: $("detail-body"),
  close: $("detail-close"),
  onSelect: select,
});

$("fit").addEventListener("click", () => map.fit(true));
$("show-ids").addEventListener("change", (e) => (map.showIds = e.target.checked));
$("show-trails").addEventListener("change", (e) => (map.showTrails = e.target.checked));

function select(id) {
  state.selected = id;
  map.selected = id;
  swarm.select(id);
  if (id != null) link.send({ op: "inspect", platform: id });
}

// The picked platform's control blocks stay fresh while it is picked.
setInterval(() => {
  if (state.selected != null) link.send({ op: "inspect", platform: state.selected });
}, 1000);

function receive(m) {
  switch (m.type) {
    case "hello":
      return hello(m);
    case "frame":
      return frame(m);
    case "swarm":
      return swarmView(m);
    case "steps":
      for (const s of m.steps) {
        timeline.put(s);
        graph.fired(s);
      }
      return;
    case "outcome":
      return controls.outcome(m);
    case "acb":
      return swarm.showAcbs(m);
    case "notice":
      return notice(m.message);
  }
}

function notice(message) {
  $("notice").textContent = message || "";
  $("notice").hidden = !message;
}

function hello(m) {
  state.hello = m;
  notice(m.failure);
  state.t0 = m.t0 || 0;
  state.names = m.script ? m.script.actors : [];
  $("title").textContent = m.title;
  $("script-name").textContent = m.script ? `${m.script.name}${m.script.sha ? " · " + m.script.sha.slice(0, 12) : ""}` : "no script";
  $("pace-box").hidden = m.kind !== "sim" && m.kind !== "replay";
  $("replay-box").hidden = m.kind !== "replay";
  showSpeed(m.speed);
  showReplay(m.replay, m.t0 || 0);
  document.body.dataset.kind = m.kind;
  showLink();
  graph.show(m.script);
  map.setAreas(m.areas);
  map.setHistory(m.trails);
  timeline.reset(m.steps, state.names, state.t0);
  controls.setScript(m.script);
  controls.reset(m.outcomes, state.t0);
}

function showSpeed(speed) {
  if (speed == null) return;
  const select = $("speed");
  const value = String(speed);
  if (![...select.options].some((o) => o.value === value)) {
    select.append(el("option", { value }, `×${value}`));
  }
  select.value = value;
}

// A replay's controls follow the server's state unless the operator is dragging the slider.
function showReplay(replay, t) {
  if (!replay) return;
  const seek = $("replay-seek");
  seek.max = String(replay.end);
  if (!state.seeking) seek.value = String(t);
  $("replay-play").textContent = replay.playing ? "Pause" : "Play";
  $("replay-play").dataset.playing = replay.playing ? "1" : "0";
  $("replay-end").textContent = `${clock(t - state.t0)} / ${clock(replay.end - state.t0)}`;
  document.body.dataset.playing = replay.playing ? "1" : "0";
}

$("replay-play").addEventListener("click", () =>
  link.send({ op: "play", playing: $("replay-play").dataset.playing !== "1" }),
);
$("replay-seek").addEventListener("input", () => (state.seeking = true));
$("replay-seek").addEventListener("change", (e) => {
  state.seeking = false;
  link.send({ op: "seek", t: Number(e.target.value) });
});

function frame(m) {
  state.names = m.names;
  timeline.setNames(m.names);
  map.setFrame(m);
  graph.counts(m.counts);
  $("clock").textContent = clock(m.t - state.t0);
  if (document.activeElement !== $("speed")) showSpeed(m.speed);
  showReplay(m.replay, m.t);
  const legend = m.names.map((n) => `${n}:${m.counts[n] || 0}`).join(",");
  if (legend !== state.legend) {
    state.legend = legend;
    $("legend").replaceChildren(
      ...m.names.map((n, i) =>
        el("span", { class: "item" }, el("i", { class: "swatch", style: `background:${colour(i)}` }), n, el("span", { class: "n" }, m.counts[n] || 0)),
      ),
      el("span", { class: "item" }, el("i", { class: "swatch", style: "background:none;border:2px solid #ffd166;border-radius:50%" }), "master"),
    );
  }
}

function swarmView(m) {
  swarm.update(m, state.names, state.t0);
  map.setVehicles(m.members);
  const joined = m.members.filter((x) => x.state === "joined").length;
  $("master").textContent = m.master == null ? "none" : String(m.master);
  $("epoch").textContent = m.epoch == null ? "—" : String(m.epoch);
  $("members").textContent = `${joined}/${m.members.length}`;
}

link.connect();
