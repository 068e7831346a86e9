// aamsim traffic viewer: draws the frames the server streams over /ws on a canvas.
// Local equirectangular projection (longitude scaled by cos of the map's central latitude),
// so distances look right over a city. No external scripts, no map tiles.
"use strict";

const FT = 0.3048, KT = 1852 / 3600;
const TRAIL_POINTS = 30;      // frames of history per aircraft, with few aircraft...
const TRAIL_BUDGET = 9000;    // ...and at most this many trail points in all (stroking them is the costly part)
const FLASH_S = 1.6;          // how long an NMAC/LoWC flash lasts on screen (wall seconds)

const canvas = document.getElementById("map");
const ctx = canvas.getContext("2d");
const $ = (id) => document.getElementById(id);

const state = {
  meta: null, frame: null, trails: new Map(), flashes: [], scale: 1, panX: 0, panY: 0, lat0: 0, cos0: 1,
  follow: "", frozen: false, drawnIds: [], drawnXY: [], lastFrameWall: null, lastFrameSimt: null,
  speedup: null, dragging: null, sliderBusy: false, ws: null,
};
window.viewerStats = { received: 0, drawn: 0, drawMs: 0, rafTimes: [] };
window.viewerState = state;  // read by the browser tests (tests/test_viewer_browser.py)

function colour(status) { return state.meta ? state.meta.status_colours[status] : "#4fa3e0"; }

// ------------------------------------------------------------------ projection
function fitView() {
  const b = state.meta.layout ? state.meta.layout.bounds : [-0.05, 0.05, -0.05, 0.05];
  state.lat0 = (b[0] + b[1]) / 2;
  state.lon0 = (b[2] + b[3]) / 2;
  state.cos0 = Math.cos(state.lat0 * Math.PI / 180);
  const w = canvas.clientWidth, h = canvas.clientHeight;
  const spanX = Math.max((b[3] - b[2]) * state.cos0, 1e-4), spanY = Math.max(b[1] - b[0], 1e-4);
  state.scale = 0.95 * Math.min(w / spanX, h / spanY);
  state.panX = 0; state.panY = 0;
}
function project(lat, lon) {
  const w = canvas.clientWidth, h = canvas.clientHeight;
  return [w / 2 + state.panX + (lon - state.lon0) * state.cos0 * state.scale,
          h / 2 + state.panY - (lat - state.lat0) * state.scale];
}
function resize() {
  const dpr = window.devicePixelRatio || 1;
  canvas.width = Math.round(canvas.clientWidth * dpr);
  canvas.height = Math.round(canvas.clientHeight * dpr);
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
}

// ------------------------------------------------------------------ drawing
function visible(f, i) {
  const altFt = f.alt[i] / FT;
  const lo = parseFloat($("alt-min").value), hi = parseFloat($("alt-max").value);
  if (!isNaN(lo) && altFt < lo) return false;
  if (!isNaN(hi) && altFt > hi) return false;
  if ($("conflict-only").checked && f.status[i] !== 1 && f.status[i] !== 2) return false;
  return true;
}

function drawMap() {
  const L = state.meta.layout;
  if (!L) return;
  ctx.lineWidth = 1;
  ctx.strokeStyle = "#4b5a3c";  // coastline (BlueSky's, when installed): olive grey, apart from the network
  for (const line of L.outline) polyline(line);
  ctx.strokeStyle = "#2c4560";
  for (const line of L.routes) polyline(line);
  ctx.font = "11px system-ui, sans-serif";
  for (const [name, lat, lon] of L.vertiports) {
    const [x, y] = project(lat, lon);
    ctx.fillStyle = "#0b1622"; ctx.strokeStyle = "#9fb3c8";
    ctx.fillRect(x - 4, y - 4, 8, 8); ctx.strokeRect(x - 4, y - 4, 8, 8);
    ctx.fillStyle = "#7f98b2"; ctx.fillText(name, x + 6, y - 5);
  }
}
function polyline(pts) {
  ctx.beginPath();
  pts.forEach(([lat, lon], k) => { const [x, y] = project(lat, lon); k ? ctx.lineTo(x, y) : ctx.moveTo(x, y); });
  ctx.stroke();
}

function drawAircraft(f) {
  // One path per state colour (trails, then triangles): thousands of aircraft cost a few fills,
  // not a save/rotate/fill/restore each.
  const ids = [], xy = [], groups = [[], [], [], []];
  for (let i = 0; i < f.ids.length; i++) {
    if (!visible(f, i)) continue;
    const [x, y] = project(f.lat[i], f.lon[i]);
    ids.push(i); xy.push([x, y]);
    (groups[f.status[i]] || groups[0]).push(ids.length - 1);
  }
  ctx.lineWidth = 1.2;
  ctx.globalAlpha = 0.4;
  groups.forEach((members, status) => {
    if (!members.length) return;
    ctx.beginPath();
    for (const k of members) {
      const trail = state.trails.get(f.ids[ids[k]]);
      if (!trail || trail.length < 2) continue;
      trail.forEach(([lat, lon], n) => { const [x, y] = project(lat, lon); n ? ctx.lineTo(x, y) : ctx.moveTo(x, y); });
    }
    ctx.strokeStyle = colour(status); ctx.stroke();
  });
  ctx.globalAlpha = 1;
  groups.forEach((members, status) => {
    if (!members.length) return;
    ctx.beginPath();
    for (const k of members) {
      const [x, y] = xy[k], a = f.trk[ids[k]] * Math.PI / 180, s = Math.sin(a), c = Math.cos(a);
      // nose 7 px ahead, wings 4.5 px aside and 5 px back, notch 2.5 px back (screen y points down)
      ctx.moveTo(x + 7 * s, y - 7 * c);
      ctx.lineTo(x + 4.5 * c - 5 * s, y + 4.5 * s + 5 * c);
      ctx.lineTo(x - 2.5 * s, y + 2.5 * c);
      ctx.lineTo(x - 4.5 * c - 5 * s, y - 4.5 * s + 5 * c);
      ctx.closePath();
    }
    ctx.fillStyle = colour(status); ctx.fill();
  });
  ctx.font = "10px system-ui, sans-serif";
  ctx.fillStyle = "#d6e2ee";
  const labels = $("show-labels").checked;
  for (let k = 0; k < ids.length; k++) {
    const id = f.ids[ids[k]];
    if (labels || id === state.follow) ctx.fillText(id, xy[k][0] + 7, xy[k][1] + 3);
  }
  state.drawnIds = ids; state.drawnXY = xy;
  return ids.length;
}

function drawFlashes(nowWall) {
  state.flashes = state.flashes.filter((e) => nowWall - e.wall < FLASH_S);
  for (const e of state.flashes) {
    const age = (nowWall - e.wall) / FLASH_S;
    const [x, y] = project(e.lat, e.lon);
    ctx.beginPath(); ctx.arc(x, y, 6 + 26 * age, 0, 2 * Math.PI);
    ctx.strokeStyle = colour(e.kind === "nmac" ? 2 : 1);
    ctx.globalAlpha = 1 - age; ctx.lineWidth = e.kind === "nmac" ? 3 : 2; ctx.stroke(); ctx.globalAlpha = 1;
  }
}

function draw(nowWall) {
  const t0 = performance.now();
  const w = canvas.clientWidth, h = canvas.clientHeight;
  ctx.clearRect(0, 0, w, h);
  if (!state.meta) return;
  const f = state.frame;
  if (f && state.follow) {
    const i = f.ids.indexOf(state.follow);
    if (i >= 0) {
      const [x, y] = project(f.lat[i], f.lon[i]);
      state.panX += w / 2 - x; state.panY += h / 2 - y;
    }
  }
  drawMap();
  let n = 0;
  if (f) n = drawAircraft(f);
  drawFlashes(nowWall);
  canvas.dataset.aircraft = String(n);
  canvas.dataset.simt = f ? String(f.simt) : "";
  const stats = window.viewerStats;
  stats.drawn += 1; stats.drawMs = performance.now() - t0;
  canvas.dataset.frames = String(stats.drawn);
}

function loop(ts) {
  const rt = window.viewerStats.rafTimes;
  rt.push(ts); if (rt.length > 120) rt.shift();
  draw(ts / 1000);
  requestAnimationFrame(loop);
}

// ------------------------------------------------------------------ frames from the server
function hms(t) {
  if (t === null || t === undefined || !isFinite(t)) return "–";
  const s = Math.max(0, t), h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60), r = s % 60;
  return `${String(h).padStart(2, "0")}:${String(m).padStart(2, "0")}:${r.toFixed(1).padStart(4, "0")}`;
}

async function reloadMap(f) {  // a live source moved on to another scenario: fetch its map
  state.meta = await (await fetch("/api/meta")).json();
  fitView();
  state.trails.clear();
  $("title").textContent = f.title || state.meta.title;
}

function onFrame(f) {
  window.viewerStats.received += 1;
  if (state.frozen) return;
  if (f.layout_seq !== undefined && f.layout_seq !== state.meta.layout_seq) {
    state.meta.layout_seq = f.layout_seq;
    reloadMap(f);
  }
  const wall = performance.now() / 1000;
  if (f.reset) { state.trails.clear(); state.flashes = []; state.lastFrameWall = null; }
  // Speed-up: sim seconds per wall second between frames (blank until two frames came).
  if (state.lastFrameWall !== null && wall > state.lastFrameWall && f.simt >= state.lastFrameSimt) {
    const s = (f.simt - state.lastFrameSimt) / (wall - state.lastFrameWall);
    state.speedup = state.speedup === null ? s : 0.8 * state.speedup + 0.2 * s;
  } else if (f.reset) state.speedup = null;
  state.lastFrameWall = wall; state.lastFrameSimt = f.simt;
  const seen = new Set(f.ids);
  for (const id of state.trails.keys()) if (!seen.has(id)) state.trails.delete(id);
  const keep = Math.max(4, Math.min(TRAIL_POINTS, Math.round(TRAIL_BUDGET / Math.max(f.ids.length, 1))));
  for (let i = 0; i < f.ids.length; i++) {
    let t = state.trails.get(f.ids[i]);
    if (!t) { t = []; state.trails.set(f.ids[i], t); }
    t.push([f.lat[i], f.lon[i]]);
    while (t.length > keep) t.shift();
  }
  for (const e of f.events || []) state.flashes.push({ ...e, wall });
  state.frame = f;
  const m = f.metrics || {};
  $("simt").textContent = hms(f.simt);
  // Replay: the playback speed asked for; live: measured. Blank until known, "paused" when stopped.
  const speed = state.meta.mode === "replay" ? (f.playing ? f.speed : null) : state.speedup;
  $("speedup").textContent = state.meta.mode === "replay" && !f.playing ? "paused"
    : speed === null ? "" : `${Math.round(speed)}x`;
  for (const k of ["airborne", "nmac", "lowc", "completed", "holding"]) $(k).textContent = m[k] ?? "–";
  if (state.meta.mode === "replay") {
    if (!state.sliderBusy) $("slider").value = String(Math.round(f.simt));
    $("play").textContent = f.playing ? "pause" : "play";
  } else if (f.finished) {
    $("connection").textContent = "simulation finished; last picture shown";
  }
}

function send(msg) {
  if (state.ws && state.ws.readyState === WebSocket.OPEN) state.ws.send(JSON.stringify(msg));
}

// The command token the server printed in this page's URL (?token=...): stack commands need it.
const commandToken = new URLSearchParams(location.search).get("token");

function connect() {
  const query = commandToken ? `?token=${encodeURIComponent(commandToken)}` : "";
  const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws${query}`);
  state.ws = ws;
  ws.onopen = () => { $("connection").textContent = state.meta.mode === "replay" ? "replay" : "live"; };
  ws.onmessage = (ev) => {
    const msg = JSON.parse(ev.data);
    if (msg.type === "frame") onFrame(msg);
    else if (msg.type === "error") showError(msg.error);
    else if (msg.type === "ack") showError("");
  };
  ws.onclose = () => { $("connection").textContent = "disconnected (reload to reconnect)"; };
}

function showError(text) { const e = $("error"); e.textContent = text; e.hidden = !text; }

// ------------------------------------------------------------------ controls
function setupControls() {
  const meta = state.meta;
  $("title").textContent = meta.title;
  const legend = $("legend");
  meta.status_names.forEach((name, k) => {
    const li = document.createElement("li");
    li.innerHTML = `<i style="background:${meta.status_colours[k]}"></i>${{ normal: "normal", lowc: "in LoWC",
      nmac: "in NMAC", holding: "holding / hovering" }[name] || name}`;
    legend.appendChild(li);
  });
  if (meta.mode === "replay") {
    $("replay-controls").hidden = false;
    const s = $("slider");
    s.min = String(Math.floor(meta.t_start)); s.max = String(Math.ceil(meta.t_end)); s.value = s.min;
    $("t0").textContent = hms(meta.t_start); $("t1").textContent = hms(meta.t_end);
    s.addEventListener("input", () => { state.sliderBusy = true; send({ op: "seek", t: parseFloat(s.value) }); });
    s.addEventListener("change", () => { state.sliderBusy = false; });
    $("play").addEventListener("click", () => send({ op: $("play").textContent === "pause" ? "pause" : "play" }));
    $("speed").addEventListener("change", () => send({ op: "speed", x: parseFloat($("speed").value) }));
    const totals = meta.totals || {}, rows = [];
    const pick = [["safety", "nmac_events", "NMAC"], ["safety", "lowc_events", "LoWC"],
      ["operational", "flights_completed", "completed"], ["operational", "airborne_holding_s", "holding [s]"],
      ["operational", "mean_delay_s", "mean delay [s]"], ["operational", "advisories", "advisories"]];
    for (const [g, k, label] of pick) {
      const v = (totals[g] || {})[k];
      if (v !== undefined && v !== null) rows.push(`<tr><th>${label}</th><td>${typeof v === "number" ?
        Math.round(v * 10) / 10 : v}</td></tr>`);
    }
    if (rows.length) { $("totals").innerHTML = rows.join(""); $("totals-section").hidden = false; }
  } else {
    $("live-controls").hidden = false;
    $("live-pause").addEventListener("click", () => {
      state.frozen = !state.frozen; $("live-pause").textContent = state.frozen ? "follow live" : "freeze view";
    });
    if (meta.allow_commands && commandToken) {
      $("command-form").hidden = false;
      $("command-form").addEventListener("submit", (ev) => {
        ev.preventDefault(); send({ op: "stack", line: $("command").value }); $("command").value = "";
      });
    }
  }
  $("follow").addEventListener("change", () => { state.follow = $("follow").value.trim().toUpperCase(); });
  canvas.addEventListener("wheel", (ev) => {
    ev.preventDefault();
    const k = Math.exp(-ev.deltaY * 0.0015), r = canvas.getBoundingClientRect();
    const cx = ev.clientX - r.left - canvas.clientWidth / 2 - state.panX;
    const cy = ev.clientY - r.top - canvas.clientHeight / 2 - state.panY;
    state.scale *= k; state.panX -= cx * (k - 1); state.panY -= cy * (k - 1);
  }, { passive: false });
  canvas.addEventListener("mousedown", (ev) => {
    state.dragging = { x: ev.clientX, y: ev.clientY, moved: false }; canvas.classList.add("dragging");
  });
  window.addEventListener("mouseup", (ev) => {
    const d = state.dragging; state.dragging = null; canvas.classList.remove("dragging");
    if (d && !d.moved) {  // a click: follow the aircraft under the pointer (or stop following)
      const hit = pick(ev);
      state.follow = hit === null ? "" : state.frame.ids[hit];
      $("follow").value = state.follow;
    }
  });
  window.addEventListener("mousemove", (ev) => {
    const d = state.dragging;
    if (d) {
      const dx = ev.clientX - d.x, dy = ev.clientY - d.y;
      if (Math.abs(dx) + Math.abs(dy) > 2) { d.moved = true; state.follow = ""; $("follow").value = ""; }
      state.panX += dx; state.panY += dy; d.x = ev.clientX; d.y = ev.clientY;
    }
    hover(ev);
  });
  canvas.addEventListener("dblclick", () => { fitView(); state.follow = ""; $("follow").value = ""; });
}

function pick(ev) {
  const r = canvas.getBoundingClientRect(), x = ev.clientX - r.left, y = ev.clientY - r.top;
  let best = null, bestD = 100;  // within 10 px
  state.drawnXY.forEach(([ax, ay], k) => {
    const d = (ax - x) ** 2 + (ay - y) ** 2;
    if (d < bestD) { bestD = d; best = state.drawnIds[k]; }
  });
  return best;
}

function hover(ev) {
  const tip = $("tooltip"), f = state.frame;
  const i = f ? pick(ev) : null;
  if (i === null) { tip.hidden = true; return; }
  const id = f.ids[i], names = state.meta.status_names;
  const route = (state.meta.routes_by_id || {})[id];
  tip.textContent = [id, `alt ${Math.round(f.alt[i] / FT)} ft (${Math.round(f.alt[i])} m)`,
    `TAS ${Math.round(f.tas[i] / KT)} kt, track ${Math.round(f.trk[i])}°`, `state ${names[f.status[i]]}`,
    route ? `route ${route}` : null, (f.advisories || {})[id] ? `advisory ${f.advisories[id]}` : null]
    .filter(Boolean).join("\n");
  const r = canvas.getBoundingClientRect();
  tip.style.left = `${ev.clientX - r.left + 12}px`; tip.style.top = `${ev.clientY - r.top + 12}px`;
  tip.hidden = false;
}

// ------------------------------------------------------------------ start
async function main() {
  resize();
  window.addEventListener("resize", () => { resize(); });
  try {
    const res = await fetch("/api/meta");
    if (!res.ok) throw new Error(`${res.status} ${await res.text()}`);
    state.meta = await res.json();
  } catch (err) {
    showError(`could not read /api/meta: ${err}`);
    return;
  }
  if (!state.meta.layout) {  // a live run announces its map with its first frame
    for (let k = 0; k < 50 && !state.meta.layout; k++) {
      await new Promise((r) => setTimeout(r, 100));
      state.meta = await (await fetch("/api/meta")).json();
    }
  }
  fitView();
  setupControls();
  connect();
  requestAnimationFrame(loop);
}
main();
