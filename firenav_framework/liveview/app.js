// firenav incident view: floor plan, tracks, positions with protection radii, latched
// alarms with acknowledgement, events. Plain JS + SVG; data from /api/building and
// /events (Server-Sent Events: the full state first, then deltas).
"use strict";

const PALETTE = ["#e6194b", "#3cb44b", "#4363d8", "#f58231", "#911eb4", "#42d4f4",
                 "#f032e6", "#9a6324", "#469990", "#800000", "#808000", "#000075"];
const CHI2_95_2D = 5.991;  // 95 % of a 2-D Gaussian lies inside this Mahalanobis radius^2
const EPOCH_FROM = 1e9;    // pipeline times from here on are UNIX times (timefmt.py)
const SVG_NS = "http://www.w3.org/2000/svg";
const CONDITION_BADGES = { man_down: "MAN DOWN", device_silent: "DEVICE SILENT",
                           untrusted: "UNTRUSTED", map_contradiction: "MAP CONTRADICTION" };

const view = { building: { floors: [], north: { x: 0, y: 1, true: false } }, floor: null,
               agents: {}, tracks: {}, order: [], bounds: null, t0: 0, now: null,
               alarms: [], diags: [], alarmsSeen: 0, focus: null, userFloor: false,
               filters: { alarm: true, other: true, link: false } };

// A pipeline time [s] as a person reads it: local clock for a live link, else t=... s.
function clockText(t) {
  if (t === null || t === undefined || !isFinite(t)) return "–";
  if (t >= EPOCH_FROM) return new Date(t * 1000).toLocaleTimeString([], { hour12: false });
  return `t=${t.toFixed(1)} s`;
}

function colour(agent) {
  if (!view.order.includes(agent)) view.order.push(agent);
  return PALETTE[view.order.indexOf(agent) % PALETTE.length];
}

function el(name, attrs, parent) {
  const e = document.createElementNS(SVG_NS, name);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (parent) parent.appendChild(e);
  return e;
}

function text(x, y, s, attrs, parent) {  // labels sit in the unflipped group: y is -y
  const t = el("text", { x: x, y: -y, ...attrs }, parent);
  t.textContent = s;
  return t;
}

function grow(x, y) {
  if (x === null || y === null || x === undefined || y === undefined) return;
  const b = view.bounds || (view.bounds = { x0: x, x1: x, y0: y, y1: y });
  b.x0 = Math.min(b.x0, x); b.x1 = Math.max(b.x1, x);
  b.y0 = Math.min(b.y0, y); b.y1 = Math.max(b.y1, y);
}

function floorOf(st) { return st.floor === undefined ? null : st.floor; }
function onFloor(floor) {
  return view.floor === null || floor === null || floor === undefined || floor === view.floor;
}
function floorInfo(f) { return view.building.floors.find(x => x.index === f); }
function floorName(f) { const i = floorInfo(f); return i ? i.name : `floor ${f}`; }
function unacked() { return view.alarms.filter(a => a.state === "unacknowledged"); }

function drawFloors() {
  const nav = document.getElementById("floors");
  nav.innerHTML = "";
  const floors = view.building.floors.map(f => f.index);
  for (const st of Object.values(view.agents))
    if (floorOf(st) !== null && !floors.includes(st.floor)) floors.push(st.floor);
  floors.sort((a, b) => a - b);
  if (view.floor === null && floors.length) view.floor = floors[0];
  const alarmed = new Set(view.alarms.filter(a => a.state !== "acknowledged")
                               .map(a => { const st = view.agents[a.agent]; return st ? floorOf(st) : a.floor; }));
  for (const f of floors) {
    const b = document.createElement("button");
    const n = Object.values(view.agents).filter(st => floorOf(st) === f).length;
    b.textContent = floorName(f);
    if (n) { const s = document.createElement("span"); s.className = "n"; s.textContent = `(${n})`; b.appendChild(s); }
    b.className = (f === view.floor ? "active" : "") + (alarmed.has(f) ? " alarmed" : "");
    b.dataset.floor = f;
    b.onclick = () => { view.floor = f; view.userFloor = true; render(); };
    nav.appendChild(b);
  }
}

function niceLength(m) {  // 1, 2, 5 x 10^k not above m
  const p = Math.pow(10, Math.floor(Math.log10(m)));
  for (const k of [5, 2, 1]) if (k * p <= m) return k * p;
  return p;
}

function drawFurniture(metresPerPixel) {
  const sc = document.getElementById("scale");
  sc.innerHTML = "";
  const len = niceLength(150 * metresPerPixel), px = len / metresPerPixel;
  el("rect", { x: 10, y: 16, width: px / 2, height: 6, fill: "#222" }, sc);
  el("rect", { x: 10 + px / 2, y: 16, width: px / 2, height: 6, fill: "#fff", stroke: "#222" }, sc);
  el("text", { x: 10, y: 12, "font-size": 11, fill: "#222" }, sc).textContent = "0";
  el("text", { x: 10 + px, y: 12, "font-size": 11, fill: "#222", "text-anchor": "middle" }, sc).textContent = `${len} m`;
  sc.setAttribute("width", px + 24);
  const no = document.getElementById("north");
  no.innerHTML = "";
  const n = view.building.north || { x: 0, y: 1, true: false };
  const deg = Math.atan2(n.x, n.y) * 180 / Math.PI;  // clockwise turn of the arrow from up
  const g = el("g", { transform: `translate(27,36) rotate(${deg})` }, no);
  el("path", { d: "M0,-22 L8,8 L0,2 L-8,8 Z", fill: "#222" }, g);
  const t = el("text", { x: 0, y: -24, "font-size": 12, "font-weight": 700, "text-anchor": "middle", fill: "#222" }, g);
  t.textContent = "N";
  const cap = el("text", { x: 27, y: 62, "font-size": 8, "text-anchor": "middle", fill: "#555" }, no);
  cap.textContent = n.true ? "true north" : "plan north";
  no.dataset.bearing = deg.toFixed(1);
}

function drawPlan(plan, labels, s) {
  const f = floorInfo(view.floor);
  document.getElementById("floor-caption").textContent =
    view.floor === null ? "" : `${floorName(view.floor)}` + (f ? ` (level ${f.z} m)` : "");
  if (!f) return;
  for (const r of f.rooms) {
    for (const ring of r.rings)
      el("polygon", { points: ring.map(p => p.join(",")).join(" "), class: `room ${r.use}` }, plan);
    if (r.name) text(r.label[0], r.label[1], r.name, { class: "room-name", "font-size": 11 * s }, labels);
  }
  for (const ring of f.obstacles) el("polygon", { points: ring.map(p => p.join(",")).join(" "), class: "obstacle", "stroke-width": s }, plan);
  for (const st of f.stairs) {
    for (const ring of st.rings)
      el("polygon", { points: ring.map(p => p.join(",")).join(" "), class: "stair" + (st.arrives ? " arrives" : ""), "stroke-width": 1.2 * s, "data-stair": st.id }, plan);
    if (!st.arrives)
      el("polyline", { points: st.path.map(p => p.join(",")).join(" "), class: "stair-line", "stroke-width": 1.5 * s, "marker-end": "url(#arrow)" }, plan);
    const at = st.arrives ? st.path[st.path.length - 1] : st.path[0];
    text(at[0], at[1] - (st.arrives ? 12 * s : 0), st.arrives ? `${st.id} ↓ ${floorName(st.from)}` : `${st.id} ↑ ${floorName(st.to)}`,
         { class: "stair-label", "font-size": 10 * s }, labels);
  }
  for (const [[x0, y0], [x1, y1]] of f.walls)
    el("line", { x1: x0, y1: y0, x2: x1, y2: y1, class: "wall", "stroke-width": 3 * s }, plan);
  for (const d of f.doors) {
    const [[x0, y0], [x1, y1]] = d.jambs;
    el("line", { x1: x0, y1: y0, x2: x1, y2: y1, class: "door", "stroke-width": 2 * s }, plan);
  }
  for (const d of f.openings) {
    const [[x0, y0], [x1, y1]] = d.jambs;
    el("line", { x1: x0, y1: y0, x2: x1, y2: y1, class: "opening", "stroke-width": 2 * s }, plan);
  }
  for (const e of f.entrances) {
    const [x, y] = e.position, dx = Math.cos(e.heading), dy = Math.sin(e.heading);
    el("line", { x1: x - 1.5 * dx, y1: y - 1.5 * dy, x2: x + 0.8 * dx, y2: y + 0.8 * dy,
                 class: "entrance", "stroke-width": 3 * s, "marker-end": "url(#arrow-in)", "data-entrance": e.id }, plan);
    text(x - 2.2 * dx, y - 2.2 * dy, `▶ ${e.id}`, { class: "entrance-label", "font-size": 12 * s, "text-anchor": "middle" }, labels);
  }
  for (const a of f.anchors) {
    el("circle", { cx: a.position[0], cy: a.position[1], r: 4 * s, class: "anchor" }, plan);
    text(a.position[0] + 6 * s, a.position[1], a.id, { "font-size": 9 * s, fill: "#d62728" }, labels);
  }
}

function ellipse(cov) {
  if (!cov || cov[0][0] === null || cov[1][1] === null) return null;
  const a = cov[0][0], bxy = cov[0][1] || 0, d = cov[1][1];
  const tr = (a + d) / 2, det = Math.sqrt(Math.max(((a - d) / 2) ** 2 + bxy * bxy, 0));
  const l1 = tr + det, l2 = Math.max(tr - det, 0);
  const deg = Math.atan2(l1 - a, bxy || 1e-12) * 180 / Math.PI;
  return { rx: Math.sqrt(CHI2_95_2D * l1), ry: Math.sqrt(CHI2_95_2D * l2),
           deg: bxy === 0 ? (a >= d ? 0 : 90) : deg };
}

function render() {
  drawFloors();
  const b = view.bounds || { x0: -10, x1: 10, y0: -10, y1: 10 };
  const pad = 3, w = Math.max(b.x1 - b.x0, 1) + 2 * pad, h = Math.max(b.y1 - b.y0, 1) + 2 * pad;
  const svg = document.getElementById("map");
  // SVG y grows downwards; the plan's y is north: shapes are drawn in groups flipped about y
  svg.setAttribute("viewBox", `${b.x0 - pad} ${-(b.y1 + pad)} ${w} ${h}`);
  const box = svg.getBoundingClientRect();
  const s = Math.max(w / Math.max(box.width, 1), h / Math.max(box.height, 1));  // metres per pixel
  const plan = document.getElementById("plan"), tracks = document.getElementById("tracks"),
        markers = document.getElementById("markers"), labels = document.getElementById("labels");
  for (const g of [plan, tracks, markers]) { g.innerHTML = ""; g.setAttribute("transform", "scale(1,-1)"); }
  labels.innerHTML = "";
  drawPlan(plan, labels, s);
  for (const [agent, pts] of Object.entries(view.tracks)) {
    const st = view.agents[agent] || {};
    const shown = pts.filter(p => onFloor(p[4]));
    if (shown.length < 1) continue;
    el("polyline", { points: shown.map(p => `${p[1]},${p[2]}`).join(" "),
                     class: "track" + (st.stale ? " stale" : ""), "data-agent": agent,
                     stroke: colour(agent), "stroke-width": 3 * s }, tracks);
  }
  const alarmedAgents = new Set(unacked().map(a => a.agent));
  for (const st of Object.values(view.agents)) {
    if (st.x === undefined || st.x === null || !onFloor(floorOf(st))) continue;
    const c = colour(st.agent), untrusted = st.trusted === false || st.conditions.untrusted;
    const e = ellipse(st.cov);
    if (e)
      el("ellipse", { cx: 0, cy: 0, rx: e.rx, ry: e.ry, class: "ellipse",
                      transform: `translate(${st.x},${st.y}) rotate(${e.deg})`, fill: c }, markers);
    if (st.protection_radius !== null && st.protection_radius !== undefined)
      el("circle", { cx: st.x, cy: st.y, r: st.protection_radius, stroke: c, "data-agent": st.agent,
                     class: "protection" + (untrusted ? " untrusted" : ""),
                     "stroke-width": (untrusted ? 2.5 : 1.5) * s }, markers);
    el("circle", { cx: st.x, cy: st.y, r: 7 * s, fill: c, stroke: untrusted ? "#e08a00" : "#000",
                   "stroke-width": (untrusted ? 3 : 1) * s, "data-agent": st.agent,
                   class: "marker" + (st.stale ? " stale" : "") + (untrusted ? " untrusted" : "") }, markers);
    if (untrusted) text(st.x, st.y, "?", { class: "untrusted-mark", "font-size": 12 * s }, labels);
    if (alarmedAgents.has(st.agent))
      el("circle", { cx: st.x, cy: st.y, r: 16 * s, class: "alarm", "stroke-width": 4 * s, "data-agent": st.agent }, markers);
    if (view.focus === st.agent)
      el("circle", { cx: st.x, cy: st.y, r: 22 * s, class: "focus-ring", "stroke-width": 2 * s }, markers);
    text(st.x + 10 * s, st.y + 8 * s, st.agent, { class: "agent-label", fill: c, "font-size": 13 * s }, labels);
  }
  drawFurniture(s);
  drawAlarms();
  drawAgents();
  drawDiagnostics();
  updateClock();
}

function drawAlarms() {
  const ul = document.getElementById("alarms");
  ul.innerHTML = "";
  const open = unacked().length;
  document.getElementById("alarm-count").textContent = open ? `(${open} unacknowledged)` : "";
  if (!view.alarms.length) {
    const li = document.createElement("li"); li.className = "none"; li.textContent = "no alarms";
    ul.appendChild(li);
  }
  for (const a of view.alarms) {
    const li = document.createElement("li");
    li.className = a.state; li.dataset.alarm = a.id; li.dataset.agent = a.agent;
    const what = document.createElement("span"); what.className = "what";
    what.textContent = `${a.agent} ${a.title}`;
    li.appendChild(what);
    const where = a.floor !== null && a.floor !== undefined ? `, ${floorName(a.floor)}` : "";
    const state = { unacknowledged: "", returned: " — condition gone, not acknowledged",
                    acknowledged: " — acknowledged" + (a.acknowledged_by ? ` by ${a.acknowledged_by}` : "") }[a.state];
    li.appendChild(document.createTextNode(` since ${clockText(a.raised_t)}${where}${state}`));
    if (a.state !== "acknowledged") {
      const btn = document.createElement("button");
      btn.textContent = "Acknowledge"; btn.className = "ack";
      btn.onclick = (ev) => { ev.stopPropagation(); acknowledge(a.id, btn); };
      li.appendChild(btn);
    }
    li.onclick = () => { focusOn(a.agent, a.floor); };
    ul.appendChild(li);
  }
}

async function acknowledge(id, btn) {
  btn.disabled = true; btn.textContent = "sending…";
  const by = document.getElementById("operator").value.trim();
  try {
    const r = await fetch("api/ack", { method: "POST", headers: { "Content-Type": "application/json" },
                                       body: JSON.stringify({ id: id, by: by }) });
    if (!r.ok) throw new Error(await r.text());
    btn.textContent = "acknowledging…";
  } catch (e) { btn.disabled = false; btn.textContent = "Acknowledge (retry)"; btn.title = String(e); }
}

function focusOn(agent, floor) {
  const st = view.agents[agent];
  const f = st && floorOf(st) !== null ? floorOf(st) : floor;
  if (f !== null && f !== undefined) view.floor = f;
  view.focus = agent;
  render();
}

function drawAgents() {
  const ul = document.getElementById("agents");
  ul.innerHTML = "";
  for (const st of Object.values(view.agents).sort((a, b) => a.agent.localeCompare(b.agent))) {
    const li = document.createElement("li");
    li.dataset.agent = st.agent;
    if (view.focus === st.agent) li.className = "focus";
    const sw = document.createElement("span");
    sw.className = "swatch"; sw.style.background = colour(st.agent);
    li.appendChild(sw);
    let where = "no position yet";
    if (st.x !== undefined && st.x !== null) {
      where = `(${st.x.toFixed(1)}, ${st.y.toFixed(1)}) m`;
      if (floorOf(st) !== null) where += `, ${floorName(st.floor)}`;
      if (st.protection_radius !== null && st.protection_radius !== undefined)
        where += `, within ${st.protection_radius.toFixed(1)} m`;
      else where += ", no error bound";
      where += ` at ${clockText(st.t)}`;
    }
    li.appendChild(document.createTextNode(`${st.agent} ${where}`));
    const flags = Object.entries(st.conditions || {}).filter(([, on]) => on).map(([k]) => k);
    if (st.trusted === false && !flags.includes("untrusted")) flags.push("untrusted");
    if (st.stale && !flags.includes("device_silent")) flags.push("stale");
    for (const flag of flags) {
      const b = document.createElement("span");
      b.className = `badge ${flag}`;
      b.textContent = CONDITION_BADGES[flag] || flag.toUpperCase();
      li.appendChild(b);
    }
    li.onclick = () => focusOn(st.agent, null);
    ul.appendChild(li);
  }
}

function drawDiagnostics() {
  const ol = document.getElementById("diagnostics");
  ol.innerHTML = "";
  let hidden = 0, shown = 0;
  for (let i = view.diags.length - 1; i >= 0 && shown < 300; i--) {
    const d = view.diags[i];
    if (!view.filters[d.category]) { hidden += d.category === "link" ? 1 : 0; continue; }
    const li = document.createElement("li");
    li.className = (d.active === false ? "cleared" : d.level) + ` ${d.category}`;
    li.dataset.code = d.code;
    const when = document.createElement("span"); when.className = "when"; when.textContent = clockText(d.t);
    li.appendChild(when);
    li.appendChild(document.createTextNode(`${d.code}${d.agent ? " " + d.agent : ""}: ${d.text}`));
    ol.appendChild(li);
    shown++;
  }
  document.getElementById("link-hidden").textContent = hidden ? `(${hidden} hidden)` : "";
}

function updateClock() {
  const now = new Date().toLocaleTimeString([], { hour12: false });
  document.getElementById("clock").textContent = `${now}` + (view.now !== null ? ` (data ${clockText(view.now)})` : "");
}

function bringForward() {  // a new unacknowledged alarm shows its firefighter's floor
  const fresh = unacked().filter(a => a.id > view.alarmsSeen);
  for (const a of view.alarms) view.alarmsSeen = Math.max(view.alarmsSeen, a.id);
  if (!fresh.length) return;
  const a = fresh.reduce((x, y) => (y.id > x.id ? y : x));
  const st = view.agents[a.agent];
  const f = st && floorOf(st) !== null ? floorOf(st) : a.floor;
  if (f !== null && f !== undefined) view.floor = f;
  view.focus = a.agent;
}

function apply(msg) {
  if (msg.type === "full") {
    view.agents = {}; view.tracks = {}; view.diags = [];
  }
  if (msg.t0 !== null && msg.t0 !== undefined) view.t0 = msg.t0;
  view.now = msg.now;
  for (const st of msg.agents) { view.agents[st.agent] = st; grow(st.x, st.y); }
  for (const a of Object.keys(view.agents).sort()) colour(a);  // colours in name order
  for (const [agent, pts] of Object.entries(msg.tracks)) {
    const t = view.tracks[agent] || (view.tracks[agent] = []);
    for (const p of pts) { p[0] += view.t0; t.push(p); grow(p[1], p[2]); }
  }
  if (msg.alarms !== null && msg.alarms !== undefined) view.alarms = msg.alarms;
  for (const d of msg.diagnostics) view.diags.push(d);
  if (view.diags.length > 2000) view.diags.splice(0, view.diags.length - 2000);
  bringForward();
  render();
  document.body.dataset.seq = msg.seq;
}

async function main() {
  view.building = await (await fetch("api/building")).json();
  document.getElementById("title").textContent = view.building.name || "firenav";
  for (const f of view.building.floors) {
    for (const [[x0, y0], [x1, y1]] of f.walls) { grow(x0, y0); grow(x1, y1); }
    for (const e of f.entrances) { grow(e.position[0] - 3, e.position[1] - 3); grow(e.position[0] + 3, e.position[1] + 3); }
  }
  for (const box of document.querySelectorAll("#filters input"))
    box.onchange = () => { view.filters[box.dataset.category] = box.checked; drawDiagnostics(); };
  render();
  setInterval(updateClock, 1000);
  const link = document.getElementById("link");
  const events = new EventSource("events");
  events.onopen = () => { link.textContent = "live"; link.className = "link-state"; };
  events.onerror = () => { link.textContent = "connection lost — retrying"; link.className = "link-state down"; };
  events.onmessage = (e) => apply(JSON.parse(e.data));
}

main();
