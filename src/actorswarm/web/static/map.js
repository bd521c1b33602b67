// The live top view: platforms with heading, trail and actor colour, the master ringed,
// targets and areas, on a metric grid (north up). Frames arrive a few times a second; the
// map draws at the screen's rate and moves each platform smoothly from its previous pose
// to its latest one, so 30 platforms glide and 200 stay readable.
//
// Without positions (a swarm that reports none, or a simulation without a world) the map
// lays the platforms out by actor, one cluster per actor, and moves them between clusters
// as they switch — the collective transitions are still there to see.
//
// A platform whose vehicle does not answer (the link to it lost, as the swarm table says
// in red) gets a red dashed ring, and its tooltip says what the vehicle said last.
//
// The canvas carries what it drew in data attributes (data-platforms, data-alive, data-t,
// data-mode, data-draw-ms, data-vehicle-alarms), so tests and scripts can read the
// rendered state.

import { colour } from "./util.js";

const TRAIL_SECONDS = 30; // of the source's time
const TRAIL_POINTS = 200;
const MASTER_RING = "#ffd166";
const ALARM_RING = "#ff5d6c";

function lerp(a, b, t) {
  return a + (b - a) * t;
}

function lerpAngle(a, b, t) {
  let d = b - a;
  while (d > Math.PI) d -= 2 * Math.PI;
  while (d < -Math.PI) d += 2 * Math.PI;
  return a + d * t;
}

/** A round length for grid lines near `target` metres: 1, 2 or 5 times a power of ten. */
function niceStep(target) {
  const power = Math.pow(10, Math.floor(Math.log10(Math.max(target, 1e-6))));
  for (const m of [1, 2, 5, 10]) if (m * power >= target) return m * power;
  return 10 * power;
}

export class SwarmMap {
  constructor(canvas, tooltip, note, { onSelect }) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d");
    this.tooltip = tooltip;
    this.note = note;
    this.onSelect = onSelect;
    this.prev = null;
    this.cur = null;
    this.curAt = 0;
    this.interval = 100;
    this.areas = {};
    this.vehicles = new Map();
    this.trails = new Map();
    this.view = { cx: 0, cy: 0, scale: 2 };
    this.fitted = false;
    this.follow = true;
    this.showIds = true;
    this.showTrails = true;
    this.selected = null;
    this.clusterPos = new Map();
    this.clusters = [];
    this.drawn = [];
    this.lastDraw = performance.now();
    this.bind();
    requestAnimationFrame((t) => this.loop(t));
  }

  // --- data ------------------------------------------------------------------------------

  /** Recent poses from the server, so a page opened mid-mission shows trails at once. */
  setHistory(samples) {
    this.trails.clear();
    for (const s of samples || []) this.addTrails(s);
  }

  /** The swarm message's members: what each platform's vehicle said, for the rings and
   * the tooltip. */
  setVehicles(members) {
    this.vehicles = new Map(members.map((m) => [m.id, { text: m.vehicle || "", alarm: !!m.vehicle_alarm }]));
  }

  setAreas(areas) {
    this.areas = areas || {};
    this.fitted = false;
  }

  reset() {
    this.prev = this.cur = null;
    this.trails.clear();
    this.clusterPos.clear();
    this.fitted = false;
  }

  setFrame(frame) {
    const arrived = performance.now();
    if (this.cur && frame.t < this.cur.t) this.reset(); // a new run
    if (this.cur) {
      const gap = Math.min(500, Math.max(40, arrived - this.curAt));
      this.interval = this.interval * 0.7 + gap * 0.3;
    }
    this.prev = this.cur;
    this.cur = frame;
    this.curAt = arrived;
    frame.index = new Map(frame.ids.map((id, i) => [id, i]));
    if (frame.x) this.addTrails(frame);
    else this.layoutClusters(frame);
  }

  addTrails(frame) {
    for (let i = 0; i < frame.ids.length; i++) {
      const x = frame.x[i];
      const y = frame.y[i];
      if (x == null) continue;
      const id = frame.ids[i];
      let trail = this.trails.get(id);
      if (!trail) this.trails.set(id, (trail = []));
      const last = trail[trail.length - 1];
      if (!last || Math.hypot(last.x - x, last.y - y) > 0.5 || frame.t - last.t > 1) {
        trail.push({ t: frame.t, x, y });
      }
      while (trail.length > TRAIL_POINTS || (trail.length && frame.t - trail[0].t > TRAIL_SECONDS)) {
        trail.shift();
      }
    }
  }

  /** Schematic positions: a cluster per actor, platforms on a small grid within it. */
  layoutClusters(frame) {
    const groups = new Map();
    frame.ids.forEach((id, i) => {
      const a = frame.a[i];
      if (!groups.has(a)) groups.set(a, []);
      groups.get(a).push(id);
    });
    const order = [...groups.keys()].sort((p, q) => (p < 0) - (q < 0) || p - q);
    const spacing = 10;
    let x0 = 0;
    this.clusters = [];
    this.targets = new Map();
    for (const a of order) {
      const ids = groups.get(a);
      const cols = Math.max(1, Math.ceil(Math.sqrt(ids.length)));
      const rows = Math.ceil(ids.length / cols);
      ids.forEach((id, k) => {
        this.targets.set(id, { x: x0 + (k % cols) * spacing, y: -Math.floor(k / cols) * spacing });
      });
      const name = a < 0 ? "no actor" : frame.names[a];
      this.clusters.push({ a, name, n: ids.length, x: x0, w: (cols - 1) * spacing, h: (rows - 1) * spacing });
      x0 += (cols - 1) * spacing + spacing * 3;
    }
  }

  // --- view ------------------------------------------------------------------------------

  bounds() {
    let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
    const take = (x, y) => {
      if (x == null || y == null) return;
      x0 = Math.min(x0, x); y0 = Math.min(y0, y); x1 = Math.max(x1, x); y1 = Math.max(y1, y);
    };
    const frame = this.cur;
    if (frame && frame.x) {
      // The swarm and its targets; areas show when they are in view.
      frame.ids.forEach((_, i) => take(frame.x[i], frame.y[i]));
      for (const t of frame.targets || []) take(t.x, t.y);
    } else if (frame) {
      for (const p of this.targets?.values() || []) take(p.x, p.y);
      y1 += 12; // the clusters' labels
    }
    if (!isFinite(x0)) return null;
    const pad = frame && frame.x ? 30 : 8;
    const minSpan = frame && frame.x ? 60 : 30;
    const cx = (x0 + x1) / 2, cy = (y0 + y1) / 2;
    const w = Math.max(x1 - x0 + 2 * pad, minSpan), h = Math.max(y1 - y0 + 2 * pad, minSpan);
    return { cx, cy, w, h };
  }

  fit(now = false) {
    this.follow = true;
    if (now) this.fitted = false;
  }

  updateView(dt) {
    if (!this.follow) return;
    const b = this.bounds();
    if (!b) return;
    const W = this.canvas.clientWidth, H = this.canvas.clientHeight;
    const scale = Math.min(W / b.w, H / b.h) * 0.92;
    // Glide towards the fitted view (jump to it the first time). The zoom only changes
    // when the swarm no longer fits or has shrunk well inside the view, so a formation
    // that breathes does not make the map pump in and out.
    const k = this.fitted ? Math.min(1, dt * 5) : 1;
    this.view.cx = lerp(this.view.cx, b.cx, k);
    this.view.cy = lerp(this.view.cy, b.cy, k);
    const s = this.view.scale;
    if (!this.fitted || s > scale || s < scale * 0.6) {
      this.view.scale = Math.exp(lerp(Math.log(s), Math.log(scale), k));
    }
    this.fitted = true;
  }

  toScreen(x, y) {
    const { cx, cy, scale } = this.view;
    return [this.canvas.clientWidth / 2 + (x - cx) * scale, this.canvas.clientHeight / 2 - (y - cy) * scale];
  }

  toWorld(sx, sy) {
    const { cx, cy, scale } = this.view;
    return [cx + (sx - this.canvas.clientWidth / 2) / scale, cy - (sy - this.canvas.clientHeight / 2) / scale];
  }

  bind() {
    const canvas = this.canvas;
    let drag = null;
    canvas.addEventListener("mousedown", (e) => {
      drag = { x: e.offsetX, y: e.offsetY, moved: false };
    });
    window.addEventListener("mouseup", (e) => {
      if (drag && !drag.moved && e.target === canvas) {
        const hit = this.hit(e.offsetX, e.offsetY);
        this.selected = hit ? hit.id : null;
        this.onSelect(this.selected);
      }
      drag = null;
      canvas.classList.remove("dragging");
    });
    canvas.addEventListener("mousemove", (e) => {
      if (drag) {
        const dx = e.offsetX - drag.x, dy = e.offsetY - drag.y;
        if (Math.abs(dx) + Math.abs(dy) > 3) drag.moved = true;
        if (drag.moved) {
          this.follow = false;
          canvas.classList.add("dragging");
          this.view.cx -= dx / this.view.scale;
          this.view.cy += dy / this.view.scale;
          drag.x = e.offsetX;
          drag.y = e.offsetY;
        }
        return;
      }
      this.showTooltip(e.offsetX, e.offsetY);
    });
    canvas.addEventListener("mouseleave", () => (this.tooltip.hidden = true));
    canvas.addEventListener(
      "wheel",
      (e) => {
        e.preventDefault();
        this.follow = false;
        const [wx, wy] = this.toWorld(e.offsetX, e.offsetY);
        this.view.scale *= Math.exp(-e.deltaY * 0.0015);
        this.view.scale = Math.min(200, Math.max(0.005, this.view.scale));
        const [sx, sy] = this.toScreen(wx, wy);
        this.view.cx += (sx - e.offsetX) / this.view.scale;
        this.view.cy -= (sy - e.offsetY) / this.view.scale;
      },
      { passive: false },
    );
    canvas.addEventListener("dblclick", () => this.fit(true));
  }

  hit(sx, sy) {
    let best = null, bestD = 14;
    for (const p of this.drawn) {
      const d = Math.hypot(p.sx - sx, p.sy - sy);
      if (d < bestD) { best = p; bestD = d; }
    }
    return best;
  }

  showTooltip(sx, sy) {
    const hit = this.hit(sx, sy);
    const tip = this.tooltip;
    if (!hit) { tip.hidden = true; return; }
    const f = this.cur;
    const i = f.index.get(hit.id);
    const flags = f.f[i];
    const actor = f.a[i] < 0 ? "no actor" : f.names[f.a[i]];
    const bits = [`<b>#${hit.id}</b>`, actor + (flags & 4 ? " (paused)" : "") + (flags & 8 ? " +" : "")];
    if (flags & 1) bits.push("<span style='color:#ffd166'>master</span>");
    if (!(flags & 2)) bits.push("<span style='color:#ff5d6c'>not heard</span>");
    if (f.x && f.x[i] != null) {
      const hd = ((90 - (f.hd[i] * 180) / Math.PI) % 360 + 360) % 360; // compass heading
      bits.push(`x ${f.x[i].toFixed(0)} m, y ${f.y[i].toFixed(0)} m, heading ${hd.toFixed(0)}°`);
    }
    const vehicle = this.vehicles.get(hit.id);
    if (vehicle && vehicle.text) {
      const span = document.createElement("span"); // the adapter's words, as text
      span.textContent = `vehicle: ${vehicle.text}`;
      if (vehicle.alarm) span.style.color = ALARM_RING;
      bits.push(span.outerHTML);
    }
    tip.innerHTML = bits.join(" · ");
    tip.hidden = false;
    tip.style.left = `${Math.min(sx + 14, this.canvas.clientWidth - tip.offsetWidth - 4)}px`;
    tip.style.top = `${Math.max(4, sy - 30)}px`;
  }

  // --- drawing ---------------------------------------------------------------------------

  loop(time) {
    const dt = Math.min(0.1, (time - this.lastDraw) / 1000);
    this.lastDraw = time;
    const began = performance.now();
    try {
      this.draw(dt);
      // How long a drawing takes (a running mean, ms): the page's own measure of whether
      // it keeps up, readable as data-draw-ms.
      this.drawMs = (this.drawMs ?? 0) * 0.9 + (performance.now() - began) * 0.1;
      this.canvas.dataset.drawMs = this.drawMs.toFixed(2);
    } finally {
      requestAnimationFrame((t) => this.loop(t));
    }
  }

  resize() {
    const dpr = window.devicePixelRatio || 1;
    const w = Math.round(this.canvas.clientWidth * dpr), h = Math.round(this.canvas.clientHeight * dpr);
    if (this.canvas.width !== w || this.canvas.height !== h) {
      this.canvas.width = w;
      this.canvas.height = h;
    }
    this.ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  }

  draw(dt) {
    this.resize();
    const ctx = this.ctx;
    const W = this.canvas.clientWidth, H = this.canvas.clientHeight;
    ctx.fillStyle = "#0b1016";
    ctx.fillRect(0, 0, W, H);
    const f = this.cur;
    if (!f) return;
    if (!f.x) this.moveClusters(dt);
    this.updateView(dt);
    this.drawGrid(W, H, !f.x);
    if (f.x) {
      this.drawAreas();
      if (this.showTrails) this.drawTrails(f);
      this.drawTargets(f);
    } else {
      this.drawClusters(f);
    }
    this.drawPlatforms(f);
    const alive = f.f.filter((flag) => flag & 2).length;
    const data = this.canvas.dataset;
    data.platforms = String(this.drawn.length);
    data.alive = String(alive);
    data.t = String(f.t);
    data.mode = f.x ? "world" : "schematic";
    this.note.textContent = f.x
      ? ""
      : "no positions reported: platforms grouped by the actor they run";
  }

  moveClusters(dt) {
    const k = Math.min(1, dt * 5);
    for (const [id, target] of this.targets || []) {
      const p = this.clusterPos.get(id);
      if (!p) this.clusterPos.set(id, { ...target });
      else { p.x = lerp(p.x, target.x, k); p.y = lerp(p.y, target.y, k); }
    }
  }

  drawGrid(W, H, schematic) {
    const ctx = this.ctx;
    if (schematic) return;
    const step = niceStep(90 / this.view.scale);
    const [x0, y1] = this.toWorld(0, 0);
    const [x1, y0] = this.toWorld(W, H);
    ctx.lineWidth = 1;
    ctx.font = "10px ui-monospace, monospace";
    ctx.fillStyle = "#3c4a59";
    for (let x = Math.ceil(x0 / step) * step; x <= x1; x += step) {
      const [sx] = this.toScreen(x, 0);
      ctx.strokeStyle = Math.abs(x) < step / 2 ? "#25313e" : "#161f29";
      ctx.beginPath(); ctx.moveTo(Math.round(sx) + 0.5, 0); ctx.lineTo(Math.round(sx) + 0.5, H); ctx.stroke();
      ctx.fillText(`${Math.round(x)}`, sx + 3, H - 4);
    }
    for (let y = Math.ceil(y0 / step) * step; y <= y1; y += step) {
      const [, sy] = this.toScreen(0, y);
      ctx.strokeStyle = Math.abs(y) < step / 2 ? "#25313e" : "#161f29";
      ctx.beginPath(); ctx.moveTo(0, Math.round(sy) + 0.5); ctx.lineTo(W, Math.round(sy) + 0.5); ctx.stroke();
      ctx.fillText(`${Math.round(y)}`, 3, sy - 3);
    }
    // Scale bar and north.
    const bar = step * this.view.scale;
    ctx.strokeStyle = "#9aa9b8";
    ctx.fillStyle = "#9aa9b8";
    ctx.lineWidth = 2;
    ctx.beginPath(); ctx.moveTo(W - 20 - bar, H - 18); ctx.lineTo(W - 20, H - 18); ctx.stroke();
    ctx.font = "11px ui-monospace, monospace";
    ctx.textAlign = "center";
    ctx.fillText(`${step} m`, W - 20 - bar / 2, H - 24);
    ctx.fillText("N", W - 20, 20);
    ctx.beginPath(); ctx.moveTo(W - 20, 24); ctx.lineTo(W - 25, 36); ctx.lineTo(W - 15, 36); ctx.closePath(); ctx.fill();
    ctx.textAlign = "left";
  }

  drawAreas() {
    const ctx = this.ctx;
    ctx.font = "11px sans-serif";
    for (const [name, polygon] of Object.entries(this.areas)) {
      if (!polygon.length) continue;
      ctx.beginPath();
      polygon.forEach(([x, y], i) => {
        const [sx, sy] = this.toScreen(x, y);
        if (i) ctx.lineTo(sx, sy); else ctx.moveTo(sx, sy);
      });
      ctx.closePath();
      ctx.fillStyle = "rgba(76, 201, 240, 0.05)";
      ctx.fill();
      ctx.setLineDash([6, 4]);
      ctx.strokeStyle = "rgba(76, 201, 240, 0.45)";
      ctx.lineWidth = 1.2;
      ctx.stroke();
      ctx.setLineDash([]);
      const top = polygon.reduce((a, b) => (b[1] > a[1] || (b[1] === a[1] && b[0] < a[0]) ? b : a));
      const [sx, sy] = this.toScreen(top[0], top[1]);
      ctx.fillStyle = "rgba(76, 201, 240, 0.8)";
      ctx.fillText(name, sx + 4, sy - 5);
    }
  }

  drawTrails(f) {
    const ctx = this.ctx;
    ctx.lineWidth = f.ids.length > 100 ? 1 : 1.5;
    ctx.lineJoin = "round";
    for (let i = 0; i < f.ids.length; i++) {
      const trail = this.trails.get(f.ids[i]);
      if (!trail || trail.length < 2) continue;
      ctx.strokeStyle = colour(f.a[i]);
      // Older half fainter than the newer half: the trail fades towards its tail.
      const half = Math.floor(trail.length / 2);
      for (const [from, to, alpha] of [[0, half, 0.16], [half, trail.length - 1, 0.42]]) {
        if (to <= from) continue;
        ctx.globalAlpha = alpha;
        ctx.beginPath();
        for (let k = from; k <= to; k++) {
          const [sx, sy] = this.toScreen(trail[k].x, trail[k].y);
          if (k === from) ctx.moveTo(sx, sy); else ctx.lineTo(sx, sy);
        }
        ctx.stroke();
      }
    }
    ctx.globalAlpha = 1;
  }

  drawTargets(f) {
    const ctx = this.ctx;
    const pulse = 6 + 3 * Math.sin(performance.now() / 250);
    for (const t of f.targets || []) {
      const [sx, sy] = this.toScreen(t.x, t.y);
      ctx.strokeStyle = "rgba(255, 93, 108, 0.5)";
      ctx.lineWidth = 1;
      ctx.beginPath(); ctx.arc(sx, sy, 8 + pulse, 0, 2 * Math.PI); ctx.stroke();
      ctx.fillStyle = "#ff5d6c";
      ctx.beginPath(); ctx.moveTo(sx, sy - 7); ctx.lineTo(sx + 7, sy); ctx.lineTo(sx, sy + 7); ctx.lineTo(sx - 7, sy); ctx.closePath(); ctx.fill();
      ctx.font = "bold 11px sans-serif";
      ctx.fillText(t.name, sx + 10, sy + 4);
    }
  }

  drawClusters() {
    const ctx = this.ctx;
    ctx.font = "bold 12px sans-serif";
    ctx.textAlign = "center";
    for (const c of this.clusters) {
      const [sx, sy] = this.toScreen(c.x + c.w / 2, 8);
      ctx.fillStyle = colour(c.a);
      ctx.fillText(`${c.name} · ${c.n}`, sx, sy);
    }
    ctx.textAlign = "left";
  }

  pose(f, i) {
    const id = f.ids[i];
    if (!f.x) {
      const p = this.clusterPos.get(id);
      return p ? { x: p.x, y: p.y, hd: null } : null;
    }
    if (f.x[i] == null) return null;
    const prev = this.prev;
    const j = prev && prev.x ? prev.index.get(id) : undefined;
    const alpha = Math.min(1, (performance.now() - this.curAt) / this.interval);
    if (j === undefined || prev.x[j] == null) return { x: f.x[i], y: f.y[i], hd: f.hd[i] };
    return {
      x: lerp(prev.x[j], f.x[i], alpha),
      y: lerp(prev.y[j], f.y[i], alpha),
      hd: lerpAngle(prev.hd[j], f.hd[i], alpha),
    };
  }

  drawPlatforms(f) {
    const ctx = this.ctx;
    const n = f.ids.length;
    const size = n > 120 ? 4.5 : n > 50 ? 6 : 7.5;
    const labels = this.showIds && (n <= 60 || this.view.scale > 4);
    this.drawn = [];
    ctx.font = "10px ui-monospace, monospace";
    let alarms = 0;
    for (let i = 0; i < n; i++) {
      const pose = this.pose(f, i);
      if (!pose) continue;
      const [sx, sy] = this.toScreen(pose.x, pose.y);
      const id = f.ids[i];
      const flags = f.f[i];
      const fill = colour(f.a[i]);
      this.drawn.push({ id, sx, sy });
      ctx.save();
      ctx.translate(sx, sy);
      if (!(flags & 2)) {
        // Not heard: a grey cross where it was last.
        ctx.strokeStyle = "#6b7785";
        ctx.lineWidth = 2;
        ctx.beginPath();
        ctx.moveTo(-size * 0.7, -size * 0.7); ctx.lineTo(size * 0.7, size * 0.7);
        ctx.moveTo(size * 0.7, -size * 0.7); ctx.lineTo(-size * 0.7, size * 0.7);
        ctx.stroke();
      } else {
        if (flags & 1) {
          ctx.strokeStyle = MASTER_RING;
          ctx.lineWidth = 2;
          ctx.beginPath(); ctx.arc(0, 0, size * 2, 0, 2 * Math.PI); ctx.stroke();
        }
        ctx.beginPath();
        if (pose.hd == null) {
          ctx.arc(0, 0, size * 0.85, 0, 2 * Math.PI);
        } else {
          ctx.rotate(-pose.hd); // world angles turn counter-clockwise; the screen's y is down
          ctx.moveTo(size * 1.6, 0);
          ctx.lineTo(-size, size * 0.9);
          ctx.lineTo(-size * 0.5, 0);
          ctx.lineTo(-size, -size * 0.9);
          ctx.closePath();
        }
        if (flags & 4) {
          ctx.strokeStyle = fill;
          ctx.lineWidth = 1.5;
          ctx.stroke();
        } else {
          ctx.fillStyle = fill;
          ctx.fill();
          ctx.strokeStyle = "rgba(0, 0, 0, 0.6)";
          ctx.lineWidth = 1;
          ctx.stroke();
        }
      }
      ctx.restore();
      if (this.vehicles.get(id)?.alarm) {
        alarms++;
        ctx.strokeStyle = ALARM_RING;
        ctx.setLineDash([4, 3]);
        ctx.lineWidth = 2;
        ctx.beginPath(); ctx.arc(sx, sy, size * 2.3, 0, 2 * Math.PI); ctx.stroke();
        ctx.setLineDash([]);
      }
      if (id === this.selected) {
        ctx.strokeStyle = "#ffffff";
        ctx.setLineDash([3, 3]);
        ctx.lineWidth = 1.2;
        ctx.beginPath(); ctx.arc(sx, sy, size * 2.6, 0, 2 * Math.PI); ctx.stroke();
        ctx.setLineDash([]);
      }
      if (labels || id === this.selected || flags & 1) {
        ctx.fillStyle = flags & 1 ? MASTER_RING : "#a9b6c3";
        ctx.fillText(flags & 1 ? `${id} M` : `${id}`, sx + size + 3, sy - size + 1);
      }
    }
    this.canvas.dataset.vehicleAlarms = String(alarms);
  }
}

