// firenav incident view: floor plan, tracks, positions with 95 % ellipses, states, timeline.
// Plain JS + SVG; data from /api/state (building) and /events (Server-Sent Events).
"use strict";

const PALETTE = ["#e6194b", "#3cb44b", "#4363d8", "#f58231", "#911eb4", "#42d4f4",
                 "#f032e6", "#9a6324", "#469990", "#800000", "#808000", "#000075"];
const CHI2_95_2D = 5.991;  // 95 % of a 2-D Gaussian lies inside this Mahalanobis radius^2
const SVG_NS = "http://www.w3.org/2000/svg";

const view = { building: { floors: [] }, floor: null, agents: {}, tracks: {}, order: [],
               bounds: null };

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

function grow(x, y) {
  if (x === null || y === null) return;
  const b = view.bounds || (view.bounds = { x0: x, x1: x, y0: y, y1: y });
  b.x0 = Math.min(b.x0, x); b.x1 = Math.max(b.x1, x);
  b.y0 = Math.min(b.y0, y); b.y1 = Math.max(b.y1, y);
}

function onFloor(floor) {
  return view.floor === null || floor === null || floor === undefined || floor === view.floor;
}

function drawFloors() {
  const nav = document.getElementById("floors");
  nav.innerHTML = "";
  const floors = view.building.floors.map(f => f.index);
  for (const pts of Object.values(view.tracks))
    for (const p of pts) if (p[4] !== null && !floors.includes(p[4])) floors.push(p[4]);
  floors.sort((a, b) => a - b);
  if (view.floor === null && floors.length) view.floor = floors[0];
  for (const f of floors) {
    const b = document.createElement("button");
    const info = view.building.floors.find(x => x.index === f);
    b.textContent = info ? info.name : `floor ${f}`;
    b.className = f === view.floor ? "active" : "";
    b.onclick = () => { view.floor = f; render(); };
    nav.appendChild(b);
  }
}

function render() {
  drawFloors();
  const b = view.bounds || { x0: -10, x1: 10, y0: -10, y1: 10 };
  const pad = 2, w = Math.max(b.x1 - b.x0, 1) + 2 * pad, h = Math.max(b.y1 - b.y0, 1) + 2 * pad;
  const svg = document.getElementById("map");
  // SVG y grows downwards; the plan's y is north: draw in a group flipped about y
  svg.setAttribute("viewBox", `${b.x0 - pad} ${-(b.y1 + pad)} ${w} ${h}`);
  const scale = Math.max(w, h) / 800;  // about one screen pixel in metres
  const plan = document.getElementById("plan"), tracks = document.getElementById("tracks"),
        markers = document.getElementById("markers");
  for (const g of [plan, tracks, markers]) { g.innerHTML = ""; g.setAttribute("transform", "scale(1,-1)"); }
  for (const f of view.building.floors) {
    if (f.index !== view.floor) continue;
    for (const [[x0, y0], [x1, y1]] of f.walls)
      el("line", { x1: x0, y1: y0, x2: x1, y2: y1, class: "wall", "stroke-width": 3 * scale }, plan);
    for (const [[x0, y0], [x1, y1]] of f.doors)
      el("line", { x1: x0, y1: y0, x2: x1, y2: y1, class: "door", "stroke-width": 4 * scale }, plan);
  }
  for (const [agent, pts] of Object.entries(view.tracks)) {
    const st = view.agents[agent] || { flags: {} };
    const shown = pts.filter(p => onFloor(p[4]));
    if (shown.length < 1) continue;
    el("polyline", { points: shown.map(p => `${p[1]},${p[2]}`).join(" "),
                     class: "track" + (st.flags.stale ? " stale" : ""), "data-agent": agent,
                     stroke: colour(agent), "stroke-width": 4 * scale }, tracks);
  }
  for (const st of Object.values(view.agents)) {
    if (st.x === undefined || st.x === null || !onFloor(st.floor)) continue;
    const c = colour(st.agent);
    const e = ellipse(st.cov);
    if (e) {
      el("ellipse", { cx: 0, cy: 0, rx: e.rx, ry: e.ry, class: "ellipse" + (st.flags.untrusted ? " untrusted" : ""),
                      transform: `translate(${st.x},${st.y}) rotate(${e.deg})`, fill: c, stroke: c,
                      "stroke-width": 1.5 * scale }, markers);
    }
    el("circle", { cx: st.x, cy: st.y, r: 6 * scale, fill: c, stroke: "#000", "stroke-width": scale,
                   class: "marker" + (st.flags.stale ? " stale" : ""), "data-agent": st.agent }, markers);
    if (st.flags.man_down)
      el("circle", { cx: st.x, cy: st.y, r: 14 * scale, class: "alarm", "stroke-width": 3 * scale }, markers);
  }
  drawAgents();
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

function drawAgents() {
  const ul = document.getElementById("agents");
  ul.innerHTML = "";
  for (const st of Object.values(view.agents).sort((a, b) => a.agent.localeCompare(b.agent))) {
    const li = document.createElement("li");
    li.dataset.agent = st.agent;
    const sw = document.createElement("span");
    sw.className = "swatch"; sw.style.background = colour(st.agent);
    li.appendChild(sw);
    const where = st.x === undefined || st.x === null ? "no position yet"
      : `(${st.x.toFixed(1)}, ${st.y.toFixed(1)}) m` + (st.floor !== null && st.floor !== undefined ? `, floor ${st.floor}` : "");
    li.appendChild(document.createTextNode(`${st.agent} ${where}`));
    for (const flag of ["stale", "untrusted", "man_down"]) {
      if (!st.flags[flag]) continue;
      const b = document.createElement("span");
      b.className = `badge ${flag}`;
      b.textContent = { stale: "STALE", untrusted: "UNTRUSTED", man_down: "MAN DOWN" }[flag];
      li.appendChild(b);
    }
    ul.appendChild(li);
  }
}

function addDiagnostics(list) {
  const ol = document.getElementById("diagnostics");
  for (const d of list) {
    const li = document.createElement("li");
    li.className = d.active === false ? "cleared" : d.level;
    li.textContent = `[${d.level}] ${d.code}${d.agent ? " " + d.agent : ""}: ${d.text}`;
    ol.insertBefore(li, ol.firstChild);
  }
  while (ol.children.length > 300) ol.removeChild(ol.lastChild);
}

function apply(delta) {
  for (const st of delta.agents) view.agents[st.agent] = st;
  for (const [agent, pts] of Object.entries(delta.tracks)) {
    const t = view.tracks[agent] || (view.tracks[agent] = []);
    for (const p of pts) { t.push(p); grow(p[1], p[2]); }
  }
  addDiagnostics(delta.diagnostics);
  render();
  document.body.dataset.version = delta.version;
}

async function main() {
  const state = await (await fetch("api/state")).json();
  view.building = state.building;
  document.getElementById("title").textContent = state.title;
  for (const f of view.building.floors)
    for (const [[x0, y0], [x1, y1]] of f.walls) { grow(x0, y0); grow(x1, y1); }
  render();
  const link = document.getElementById("link");
  const events = new EventSource("events");
  events.onopen = () => { link.textContent = "live"; link.className = "link-state"; };
  let first = true;  // every (re)connection starts with the whole state
  events.onerror = () => { link.textContent = "connection lost — retrying"; link.className = "link-state down"; first = true; };
  events.onmessage = (e) => {
    if (first) { view.tracks = {}; document.getElementById("diagnostics").innerHTML = ""; first = false; }
    apply(JSON.parse(e.data));
  };
}

main();
