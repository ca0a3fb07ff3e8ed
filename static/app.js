// The dashboard page: draws the floor plan and the fleet from the /ws/events feed
// (format: docs/dashboard.md) and drives the REST API for the controls.
//
// Speed matters at 200 AGVs: the static layout is drawn once to an offscreen canvas,
// the fleet is drawn every animation frame with one path per colour, and the side
// panels are rebuilt a few times a second by patching rows in place.

import { currentRole, loginEnded } from "./access.js";

const PANEL_INTERVAL_MS = 250;
const CHART_INTERVAL_MS = 1000;
const CHART_SAMPLES = 120;
const MAX_SESSION_ROWS = 150;
const LABEL_LIMIT = 80;
// Shown at once; every other metric goes under "all metrics".
const KEY_METRICS = [
  "tasks_created", "tasks_completed", "tasks_per_hour", "messages", "bytes",
  "collisions", "lock_overlaps", "deadlocks",
  // With VDA 5050 (objectplaces demo --vda5050): the bridge's broker.
  "vda5050_broker_connected", "vda5050_messages_per_s", "vda5050_vehicles_online",
];
const STATION_HIT_PX = 12;
// Station kinds where a click creates a transport task (the fleet's pick stations).
const TASK_KINDS = ["pick", "pickdrop"];

const COLORS = {
  path: "#3b4a5a",
  pathBidirectional: "#58708a",
  arrow: "#7f95ab",
  point: "#4a5b6c",
  station: {
    pick: "#ff8a3d", drop: "#ffc46b", pickdrop: "#ff6b6b", parking: "#5c6bc0", charging: "#b388ff",
    other: "#ff8a3d",
  },
  status: {
    idle: "#7f8c99", driving: "#4aa3ff", moving: "#4aa3ff", waiting: "#ff9f43",
    blocked: "#ff9f43", loading: "#00d2d3", unloading: "#00d2d3", charging: "#b388ff",
    failed: "#ff5e57", crashed: "#ff5e57", stopping: "#f368e0", stopped: "#f368e0",
    "out-of-service": "#576574", "to-charger": "#b388ff", empty: "#ff5e57", other: "#48dbfb",
  },
  lockedFill: "rgba(46, 204, 113, 0.22)",
  lockedStroke: "rgba(46, 204, 113, 0.85)",
  requestedFill: "rgba(241, 196, 15, 0.14)",
  requestedStroke: "rgba(241, 196, 15, 0.9)",
  circle: "rgba(95, 211, 230, 0.7)",
  circleHover: "rgba(95, 211, 230, 1)",
  session: "rgba(224, 86, 253, 0.75)",
  sessionApi: "rgba(255, 120, 255, 1)",
  hullStroke: "rgba(8, 12, 16, 0.9)",
  label: "#e8eef4",
};

// ---- legend: one entry per colour a hull or a station can take, from COLORS ----------

// Statuses (or station kinds) sharing a colour share an entry: "driving / moving".
function legendEntries(colors) {
  const byColor = new Map();
  for (const [name, color] of Object.entries(colors)) {
    if (!byColor.has(color)) byColor.set(color, []);
    byColor.get(color).push(name);
  }
  return [...byColor].map(([color, names]) => ({ color, names }));
}

function buildLegend() {
  const legend = document.getElementById("legend");
  const groups = [
    ["hull", "hull-colors", COLORS.status, "data-hull-status"],
    ["station (click a pick station: add a task)", "station-colors", COLORS.station, "data-station-kind"],
  ];
  for (const [title, id, colors, attr] of groups) {
    const li = document.createElement("li");
    li.id = id;
    li.className = "legend-group";
    li.append(`${title}:`);
    for (const { color, names } of legendEntries(colors)) {
      const entry = document.createElement("span");
      entry.className = "legend-entry";
      entry.setAttribute(attr, names.join(" "));
      const swatch = document.createElement("i");
      swatch.className = "sw";
      swatch.style.background = color;
      entry.append(swatch, names.join(" / "));
      li.append(entry);
    }
    legend.append(li);
  }
}

buildLegend();

// ---- state fed by the event stream -------------------------------------------------

const state = {
  layout: null,
  stationsById: new Map(),
  vehicles: new Map(), // id -> record (+ interpolation fields)
  sessions: new Map(), // id -> record
  nodes: new Map(), // id -> {messages, bytes, ...}
  metrics: {},
  sim: { paused: false, speed: 1, stop: "running" },
  now: 0,
  messages: 0,
  lastDeltaAt: 0,
  frameInterval: 50,
  panelsDirty: true,
  lastTask: null,
};

// ---- view transform ----------------------------------------------------------------

const canvas = document.getElementById("floor");
const ctx = canvas.getContext("2d");
const layer = document.createElement("canvas");
const layerCtx = layer.getContext("2d");
const view = { scale: 1, ox: 0, oy: 0, dpr: 1, width: 0, height: 0, fitted: false, layerDirty: true };

function toScreen(x, y) {
  return [view.ox + x * view.scale, view.oy - y * view.scale];
}

function toWorld(sx, sy) {
  return [(sx - view.ox) / view.scale, (view.oy - sy) / view.scale];
}

function fitView() {
  if (!state.layout) return;
  const [x0, y0, x1, y1] = state.layout.bounds;
  // Room at the top for the legend, and around for station labels.
  const side = 30;
  const legend = document.getElementById("legend");
  const top = legend.offsetTop + legend.offsetHeight + 8;
  const bottom = 24;
  const w = Math.max(x1 - x0, 1);
  const h = Math.max(y1 - y0, 1);
  view.scale = Math.max(0.01, Math.min((view.width - 2 * side) / w, (view.height - top - bottom) / h));
  view.ox = (view.width - w * view.scale) / 2 - x0 * view.scale;
  view.oy = top + (view.height - top - bottom + h * view.scale) / 2 + y0 * view.scale;
  view.fitted = true;
  view.layerDirty = true;
}

function resize() {
  const rect = canvas.getBoundingClientRect();
  view.dpr = window.devicePixelRatio || 1;
  view.width = Math.max(1, rect.width);
  view.height = Math.max(1, rect.height);
  for (const c of [canvas, layer]) {
    c.width = Math.round(view.width * view.dpr);
    c.height = Math.round(view.height * view.dpr);
  }
  fitView();
  view.layerDirty = true;
}

function worldTransform(c) {
  const k = view.scale * view.dpr;
  c.setTransform(k, 0, 0, -k, view.ox * view.dpr, view.oy * view.dpr);
}

// ---- the static layer ----------------------------------------------------------------

function polylinePath(c, pts) {
  c.moveTo(pts[0][0], pts[0][1]);
  for (let i = 1; i < pts.length; i++) c.lineTo(pts[i][0], pts[i][1]);
}

function drawLayer() {
  const c = layerCtx;
  c.setTransform(1, 0, 0, 1, 0, 0);
  c.clearRect(0, 0, layer.width, layer.height);
  if (!state.layout) return;
  const px = 1 / view.scale; // one screen pixel in metres
  worldTransform(c);
  c.lineCap = "round";
  c.lineJoin = "round";
  for (const bidirectional of [false, true]) {
    c.beginPath();
    for (const s of state.layout.segments) {
      if (s.bidirectional === bidirectional && s.polyline.length > 1) polylinePath(c, s.polyline);
    }
    c.strokeStyle = bidirectional ? COLORS.pathBidirectional : COLORS.path;
    c.lineWidth = (bidirectional ? 4 : 2.5) * px;
    c.stroke();
  }
  // One-way arrows at each one-way path's midpoint, pointing to its end.
  c.beginPath();
  const size = 6 * px;
  for (const s of state.layout.segments) {
    if (s.bidirectional || s.polyline.length < 2) continue;
    const mid = midpointWithDirection(s.polyline);
    if (!mid) continue;
    const [mx, my, dx, dy] = mid;
    c.moveTo(mx + dx * size, my + dy * size);
    c.lineTo(mx - dx * size - dy * size * 0.7, my - dy * size + dx * size * 0.7);
    c.lineTo(mx - dx * size + dy * size * 0.7, my - dy * size - dx * size * 0.7);
    c.closePath();
  }
  c.fillStyle = COLORS.arrow;
  c.fill();
  c.beginPath();
  for (const p of state.layout.points) {
    c.moveTo(p.x + 2 * px, p.y);
    c.arc(p.x, p.y, 2 * px, 0, Math.PI * 2);
  }
  c.fillStyle = COLORS.point;
  c.fill();
  // Stations can sit 1.25 m apart: keep markers and labels from running together.
  const half = Math.min(6, 0.4 * view.scale) * px;
  for (const st of state.layout.stations) {
    c.fillStyle = COLORS.station[st.kind] || COLORS.station.other;
    c.fillRect(st.x - half, st.y - half, 2 * half, 2 * half);
  }
  // Labels in screen space, so the text is not mirrored by the y-up transform.
  c.setTransform(view.dpr, 0, 0, view.dpr, 0, 0);
  c.font = "11px system-ui, sans-serif";
  c.fillStyle = "#c9d3dd";
  c.textBaseline = "middle";
  const roomy = view.scale >= 40;
  for (const st of state.layout.stations) {
    if (!roomy && (st.kind === "parking" || st.kind === "charging")) continue;
    const [sx, sy] = toScreen(st.x, st.y);
    c.fillText(st.id, sx + half * view.scale + 3, sy - half * view.scale - 3);
  }
  view.layerDirty = false;
}

function midpointWithDirection(pts) {
  let total = 0;
  for (let i = 1; i < pts.length; i++) total += Math.hypot(pts[i][0] - pts[i - 1][0], pts[i][1] - pts[i - 1][1]);
  if (total <= 0) return null;
  let walked = 0;
  for (let i = 1; i < pts.length; i++) {
    const [ax, ay] = pts[i - 1];
    const [bx, by] = pts[i];
    const len = Math.hypot(bx - ax, by - ay);
    if (walked + len >= total / 2 && len > 0) {
      const t = (total / 2 - walked) / len;
      return [ax + (bx - ax) * t, ay + (by - ay) * t, (bx - ax) / len, (by - ay) / len];
    }
    walked += len;
  }
  return null;
}

// ---- the fleet, every frame --------------------------------------------------------------

const overlays = [];

const ui = {
  showCircles: false,
  showSessions: true,
  showLabels: false,
  hoverVehicle: null,
  hoverStation: null,
};

function interpolation(nowMs) {
  return Math.min(1, (nowMs - state.lastDeltaAt) / state.frameInterval);
}

// Where a vehicle is drawn this frame: it glides from where it was drawn when the last
// update arrived to where that update put it, so 20 updates a second look smooth.
function drawnOffset(v, t) {
  return [(v.fromX - v.x) * (1 - t), (v.fromY - v.y) * (1 - t)];
}

function polygonsPath(c, polygons) {
  for (const poly of polygons) {
    if (poly.length < 3) continue;
    polylinePath(c, poly);
    c.closePath();
  }
}

function nodePosition(id, t) {
  const v = state.vehicles.get(id);
  if (v) {
    const [dx, dy] = drawnOffset(v, t);
    return [v.x + dx, v.y + dy];
  }
  const fixed = state.layout.nodes && state.layout.nodes[id];
  if (fixed) return fixed;
  const st = state.stationsById.get(id);
  return st ? [st.x, st.y] : null;
}

function drawFrame(nowMs) {
  if (view.layerDirty) drawLayer();
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  ctx.drawImage(layer, 0, 0);
  if (!state.layout) return;
  const px = 1 / view.scale;
  const t = interpolation(nowMs);
  worldTransform(ctx);
  ctx.lineJoin = "round";

  // Projections: one path per kind, so 200 AGVs cost two fills and two strokes.
  ctx.beginPath();
  for (const v of state.vehicles.values()) polygonsPath(ctx, v.locked);
  ctx.fillStyle = COLORS.lockedFill;
  ctx.fill("nonzero");
  ctx.strokeStyle = COLORS.lockedStroke;
  ctx.lineWidth = px;
  ctx.stroke();

  ctx.beginPath();
  for (const v of state.vehicles.values()) polygonsPath(ctx, v.requested);
  ctx.fillStyle = COLORS.requestedFill;
  ctx.fill("nonzero");
  ctx.setLineDash([4 * px, 3 * px]);
  ctx.strokeStyle = COLORS.requestedStroke;
  ctx.stroke();
  // Dashed strokes are slow to rasterise without a GPU; circles are long, keep them solid.
  ctx.setLineDash([]);

  // Hull-projection circles: all of them on the toggle, the hovered one always.
  ctx.beginPath();
  for (const v of state.vehicles.values()) {
    if (!ui.showCircles && v.id !== ui.hoverVehicle) continue;
    const [dx, dy] = drawnOffset(v, t);
    const r = Math.max(v.hull_length, 0.01);
    ctx.moveTo(v.x + dx + r, v.y + dy);
    ctx.arc(v.x + dx, v.y + dy, r, 0, Math.PI * 2);
  }
  ctx.strokeStyle = ui.showCircles ? COLORS.circle : COLORS.circleHover;
  ctx.lineWidth = px;
  ctx.stroke();

  if (ui.showSessions) drawSessionLines(px, t);

  // Hulls grouped by status colour.
  const groups = new Map();
  for (const v of state.vehicles.values()) {
    const color = COLORS.status[v.status] || COLORS.status.other;
    let list = groups.get(color);
    if (!list) groups.set(color, (list = []));
    list.push(v);
  }
  ctx.lineWidth = px;
  ctx.strokeStyle = COLORS.hullStroke;
  for (const [color, list] of groups) {
    ctx.beginPath();
    for (const v of list) {
      const [dx, dy] = drawnOffset(v, t);
      const hull = v.hull;
      if (hull.length < 3) continue;
      ctx.moveTo(hull[0][0] + dx, hull[0][1] + dy);
      for (let i = 1; i < hull.length; i++) ctx.lineTo(hull[i][0] + dx, hull[i][1] + dy);
      ctx.closePath();
    }
    ctx.fillStyle = color;
    ctx.fill();
    ctx.stroke();
  }
  // Heading ticks: centre to front.
  ctx.beginPath();
  for (const v of state.vehicles.values()) {
    const [dx, dy] = drawnOffset(v, t);
    const reach = v.length * 0.45;
    ctx.moveTo(v.x + dx, v.y + dy);
    ctx.lineTo(v.x + dx + Math.cos(v.heading) * reach, v.y + dy + Math.sin(v.heading) * reach);
  }
  ctx.strokeStyle = "rgba(255, 255, 255, 0.8)";
  ctx.lineWidth = 1.5 * px;
  ctx.stroke();

  // Drawings of other modules (the selected AGV's route, a group view), in world space.
  for (const draw of overlays) {
    ctx.save();
    draw(ctx, { px, position: (id) => nodePosition(id, t) });
    ctx.restore();
  }
  if (ui.showLabels || ui.hoverVehicle) drawLabels(t);
  if (ui.hoverStation) {
    const st = state.stationsById.get(ui.hoverStation);
    if (st) {
      ctx.beginPath();
      ctx.arc(st.x, st.y, 11 * px, 0, Math.PI * 2);
      ctx.strokeStyle = "#ffffff";
      ctx.lineWidth = 2 * px;
      ctx.stroke();
    }
  }
}

function drawSessionLines(px, t) {
  for (const apiOnly of [false, true]) {
    ctx.beginPath();
    for (const s of state.sessions.values()) {
      if (Boolean(s.via_api) !== apiOnly || s.members.length === 0) continue;
      const from = nodePosition(s.node, t);
      if (!from) continue;
      for (const m of s.members) {
        const to = nodePosition(m, t);
        if (!to) continue;
        ctx.moveTo(from[0], from[1]);
        ctx.lineTo(to[0], to[1]);
      }
    }
    ctx.strokeStyle = apiOnly ? COLORS.sessionApi : COLORS.session;
    ctx.lineWidth = (apiOnly ? 2 : 1.2) * px;
    ctx.stroke();
  }
}

function drawLabels(t) {
  ctx.setTransform(view.dpr, 0, 0, view.dpr, 0, 0);
  ctx.font = "11px system-ui, sans-serif";
  ctx.fillStyle = COLORS.label;
  ctx.textBaseline = "bottom";
  let drawn = 0;
  for (const v of state.vehicles.values()) {
    if (!ui.showLabels && v.id !== ui.hoverVehicle) continue;
    if (drawn++ >= LABEL_LIMIT && v.id !== ui.hoverVehicle) continue;
    const [dx, dy] = drawnOffset(v, t);
    const [sx, sy] = toScreen(v.x + dx, v.y + dy);
    ctx.fillText(v.id, sx + 6, sy - 6);
  }
}

// ---- the feed ------------------------------------------------------------------------------

function applyVehicle(id, fields, nowMs) {
  let v = state.vehicles.get(id);
  const t = interpolation(nowMs);
  if (!v) {
    v = { id, locked: [], requested: [], hull: [], fromX: 0, fromY: 0 };
    state.vehicles.set(id, v);
    Object.assign(v, fields);
    v.fromX = v.x;
    v.fromY = v.y;
    return;
  }
  if ("x" in fields || "y" in fields) {
    const [dx, dy] = drawnOffset(v, t);
    v.fromX = v.x + dx;
    v.fromY = v.y + dy;
  }
  Object.assign(v, fields);
}

function applySnapshot(msg, nowMs) {
  state.layout = msg.layout;
  state.stationsById = new Map(msg.layout.stations.map((s) => [s.id, s]));
  state.vehicles = new Map();
  for (const [id, rec] of Object.entries(msg.vehicles)) applyVehicle(id, rec, nowMs);
  state.sessions = new Map(msg.sessions.map((s) => [s.id, s]));
  state.nodes = new Map(Object.entries(msg.nodes));
  state.metrics = { ...msg.metrics };
  state.sim = msg.sim;
  state.now = msg.now;
  view.fitted = false;
  fitView();
  resetCharts();
}

function applyDelta(msg, nowMs) {
  state.now = msg.now;
  if (msg.sim) state.sim = msg.sim;
  if (msg.vehicles) for (const [id, f] of Object.entries(msg.vehicles)) applyVehicle(id, f, nowMs);
  if (msg.locks) {
    for (const [id, f] of Object.entries(msg.locks)) {
      const v = state.vehicles.get(id);
      if (v) Object.assign(v, f);
    }
  }
  if (msg.vehicles_removed) for (const id of msg.vehicles_removed) state.vehicles.delete(id);
  if (msg.sessions_started) for (const s of msg.sessions_started) state.sessions.set(s.id, s);
  if (msg.sessions_stopped) for (const id of msg.sessions_stopped) state.sessions.delete(id);
  if (msg.members) {
    for (const [id, members] of Object.entries(msg.members)) {
      const s = state.sessions.get(id);
      if (s) s.members = members;
    }
  }
  if (msg.metrics) Object.assign(state.metrics, msg.metrics);
  if (msg.nodes) for (const [id, n] of Object.entries(msg.nodes)) state.nodes.set(id, n);
  if (msg.nodes_removed) for (const id of msg.nodes_removed) state.nodes.delete(id);
}

const connStatus = document.getElementById("conn-status");
let socket = null;
let retryMs = 500;

function connect() {
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  socket = new WebSocket(`${scheme}://${location.host}/ws/events`);
  socket.addEventListener("open", () => {
    retryMs = 500;
    connStatus.textContent = "live";
    connStatus.className = "conn up";
  });
  socket.addEventListener("message", (event) => {
    const nowMs = performance.now();
    let msg;
    try {
      msg = JSON.parse(event.data);
    } catch {
      return;
    }
    state.messages++;
    if (msg.type === "snapshot") {
      applySnapshot(msg, nowMs);
    } else if (msg.type === "delta" && state.layout) {
      // Interpolate over the gap the feed actually has, within reason.
      const gap = nowMs - state.lastDeltaAt;
      state.frameInterval = Math.max(30, Math.min(200, gap));
      applyDelta(msg, nowMs);
    }
    state.lastDeltaAt = nowMs;
    state.panelsDirty = true;
  });
  socket.addEventListener("close", () => {
    connStatus.textContent = "reconnecting";
    connStatus.className = "conn down";
    currentRole(); // off to the login page if the login has ended
    setTimeout(connect, retryMs);
    retryMs = Math.min(retryMs * 2, 5000);
  });
  // An error is always followed by "close", which reconnects.
  socket.addEventListener("error", () => {});
}

// ---- REST -----------------------------------------------------------------------------------

const controlStatus = document.getElementById("control-status");

// A report clears itself after a while; an error stays until a later request works.
const SAY_CLEAR_MS = 6000;
let sayTimer = null;

function say(text, isError = false) {
  controlStatus.textContent = text;
  controlStatus.className = isError ? "status error" : "status";
  clearTimeout(sayTimer);
  if (text && !isError) sayTimer = setTimeout(() => say(""), SAY_CLEAR_MS);
}

// Changes go with the login cookie; the server takes them only from this page's origin.
async function post(path, body) {
  const headers = { "Content-Type": "application/json" };
  let response;
  try {
    response = await fetch(path, { method: "POST", headers, body: JSON.stringify(body ?? {}) });
  } catch (err) {
    say(`request failed: ${err.message}`, true);
    return null;
  }
  if (loginEnded(response)) return null;
  let data = null;
  try {
    data = await response.json();
  } catch {
    data = null;
  }
  if (!response.ok) {
    say(`${path}: ${data && data.detail ? JSON.stringify(data.detail) : response.status}`, true);
    return null;
  }
  return data;
}

async function addTask(stationId) {
  const data = await post("/api/tasks", { station: stationId });
  if (data) {
    state.lastTask = { id: data.task_id, station: stationId };
    say(`task ${data.task_id} created at ${stationId}`);
  }
}

// ---- session detail: fetched on click, refreshed while shown ----------------------------

const sessionDetail = document.getElementById("session-detail");
let selectedSession = null;

async function refreshSessionDetail() {
  if (!selectedSession) return;
  const id = selectedSession;
  // Ask only about sessions the feed still shows: an ended one would answer 404.
  if (!state.sessions.has(id)) {
    selectedSession = null;
    setText(sessionDetail, `${sessionDetail.textContent}\n(session ended)`);
    return;
  }
  let text;
  try {
    const response = await fetch(`/api/sessions/${encodeURIComponent(id)}`);
    const data = await response.json();
    if (response.ok) {
      const { id: sid, role, node, participant_role: prole, members, age_s: age, definition, detail } = data;
      text = JSON.stringify({ id: sid, role, node, participant_role: prole, members, age_s: Number(age.toFixed(2)), definition, detail }, null, 1);
    } else {
      text = data.detail;
    }
  } catch (err) {
    text = `request failed: ${err.message}`;
  }
  if (selectedSession === id) {
    sessionDetail.hidden = false;
    setText(sessionDetail, text);
  }
}

document.getElementById("sessions-body").addEventListener("click", (event) => {
  const row = event.target.closest("tr[data-session-id]");
  if (!row) return;
  const id = row.getAttribute("data-session-id");
  selectedSession = selectedSession === id ? null : id;
  for (const r of row.parentElement.children) r.classList.toggle("selected", r.getAttribute("data-session-id") === selectedSession);
  if (selectedSession) {
    refreshSessionDetail();
  } else {
    sessionDetail.hidden = true;
  }
});

// ---- pointer ------------------------------------------------------------------------------

const tooltip = document.getElementById("tooltip");
const drag = { active: false, moved: false, x: 0, y: 0 };

function stationAt(sx, sy) {
  if (!state.layout) return null;
  let best = null;
  let bestD = STATION_HIT_PX;
  for (const st of state.layout.stations) {
    const [x, y] = toScreen(st.x, st.y);
    const d = Math.hypot(x - sx, y - sy);
    if (d <= bestD) {
      best = st.id;
      bestD = d;
    }
  }
  return best;
}

function vehicleAt(sx, sy) {
  const [wx, wy] = toWorld(sx, sy);
  let best = null;
  let bestD = Infinity;
  for (const v of state.vehicles.values()) {
    const d = Math.hypot(v.x - wx, v.y - wy);
    const reach = Math.max(v.length, v.width) * 0.6 + 6 / view.scale;
    if (d <= reach && d < bestD) {
      best = v;
      bestD = d;
    }
  }
  return best;
}

function localPoint(event) {
  const rect = canvas.getBoundingClientRect();
  return [event.clientX - rect.left, event.clientY - rect.top];
}

canvas.addEventListener("mousemove", (event) => {
  const [sx, sy] = localPoint(event);
  if (drag.active) {
    const dx = sx - drag.x;
    const dy = sy - drag.y;
    if (Math.abs(dx) + Math.abs(dy) > 2) drag.moved = true;
    view.ox += dx;
    view.oy += dy;
    drag.x = sx;
    drag.y = sy;
    view.layerDirty = true;
    return;
  }
  // An AGV wins over the station it stands on: it is what the pointer shows on top.
  const v = vehicleAt(sx, sy);
  ui.hoverVehicle = v ? v.id : null;
  ui.hoverStation = v ? null : stationAt(sx, sy);
  const st = ui.hoverStation ? state.stationsById.get(ui.hoverStation) : null;
  canvas.classList.toggle("over-station", Boolean(v) || Boolean(st && takesTasks(st)));
  if (v) {
    tooltip.hidden = false;
    tooltip.textContent =
      `${v.id}  ${v.status}\ntask ${v.task ?? "–"}\nhull length ${v.hull_length.toFixed(2)} m\n` +
      `locked ${v.locked.length}  requested ${v.requested.length}\nclick: details and route`;
  } else if (st) {
    tooltip.hidden = false;
    tooltip.textContent = takesTasks(st)
      ? `${st.id} (${st.kind})\nclick: add a transport task here`
      : `${st.id} (${st.kind})\nno tasks start here`;
  } else {
    tooltip.hidden = true;
  }
  tooltip.style.left = `${sx + 14}px`;
  tooltip.style.top = `${sy + 14}px`;
});

canvas.addEventListener("mouseleave", () => {
  ui.hoverStation = null;
  ui.hoverVehicle = null;
  tooltip.hidden = true;
  drag.active = false;
  canvas.classList.remove("dragging");
});

canvas.addEventListener("mousedown", (event) => {
  const [sx, sy] = localPoint(event);
  drag.active = true;
  drag.moved = false;
  drag.x = sx;
  drag.y = sy;
  canvas.classList.add("dragging");
});

canvas.addEventListener("mouseup", (event) => {
  const wasDrag = drag.moved;
  drag.active = false;
  canvas.classList.remove("dragging");
  if (wasDrag) return;
  const [sx, sy] = localPoint(event);
  const v = vehicleAt(sx, sy);
  if (v) {
    document.dispatchEvent(new CustomEvent("vehicle-select", { detail: v.id }));
    return;
  }
  const st = state.stationsById.get(stationAt(sx, sy));
  if (st && takesTasks(st)) addTask(st.id);
});

function takesTasks(station) {
  return TASK_KINDS.includes(station.kind);
}

canvas.addEventListener("dblclick", () => {
  fitView();
});

canvas.addEventListener(
  "wheel",
  (event) => {
    event.preventDefault();
    const [sx, sy] = localPoint(event);
    const [wx, wy] = toWorld(sx, sy);
    const factor = Math.exp(-event.deltaY * 0.0015);
    view.scale = Math.min(1000, Math.max(0.05, view.scale * factor));
    view.ox = sx - wx * view.scale;
    view.oy = sy + wy * view.scale;
    view.layerDirty = true;
  },
  { passive: false },
);

// ---- controls ---------------------------------------------------------------------------

// The answer is the fleet's clock state: show it at once rather than at the next delta.
async function simAction(path, body) {
  const sim = await post(path, body);
  if (sim) {
    state.sim = { paused: sim.paused, speed: sim.speed, stop: sim.stop || "running" };
    state.panelsDirty = true;
    updatePanels();
    if (state.sim.stop !== "running") say(state.sim.stop === "stopped" ? "fleet stopped" : "fleet stop asked");
    else say(sim.paused ? "fleet paused" : `fleet running at ${sim.speed}×`);
  }
}

document.getElementById("btn-pause").addEventListener("click", () => simAction("/api/sim/pause"));
document.getElementById("btn-resume").addEventListener("click", () => simAction("/api/sim/resume"));
const speedSelect = document.getElementById("speed");
speedSelect.addEventListener("change", () => simAction("/api/sim/speed", { factor: Number(speedSelect.value) }));
document.getElementById("toggle-circles").addEventListener("change", (e) => (ui.showCircles = e.target.checked));
document.getElementById("toggle-sessions").addEventListener("change", (e) => (ui.showSessions = e.target.checked));
document.getElementById("toggle-labels").addEventListener("change", (e) => (ui.showLabels = e.target.checked));

// ---- panels: patched in place a few times a second --------------------------------------

function setText(el, text) {
  if (el.textContent !== text) el.textContent = text;
}

// Make tbody show `items` in order, reusing the row of each key and touching only
// cells whose text changed.
function syncRows(tbody, items, keyAttr, cellsOf, decorate) {
  const existing = new Map();
  for (const row of tbody.children) existing.set(row.getAttribute(keyAttr), row);
  let ref = tbody.firstElementChild;
  const keep = new Set();
  for (const item of items) {
    const key = item.key;
    keep.add(key);
    let row = existing.get(key);
    const cells = cellsOf(item);
    if (!row) {
      row = document.createElement("tr");
      row.setAttribute(keyAttr, key);
      for (const c of cells) {
        const td = document.createElement("td");
        if (c.cls) td.className = c.cls;
        row.append(td);
      }
    }
    cells.forEach((c, i) => {
      const td = row.children[i];
      setText(td, c.text);
      if (c.attr) for (const [k, v] of Object.entries(c.attr)) if (td.getAttribute(k) !== v) td.setAttribute(k, v);
    });
    if (decorate) decorate(row, item);
    if (row === ref) {
      ref = ref.nextElementSibling;
    } else {
      tbody.insertBefore(row, ref);
    }
  }
  for (const [key, row] of existing) if (!keep.has(key)) row.remove();
}

function fmtCount(n) {
  if (n == null) return "–";
  if (n >= 1e9) return `${(n / 1e9).toFixed(2)} G`;
  if (n >= 1e6) return `${(n / 1e6).toFixed(2)} M`;
  if (n >= 1e4) return `${(n / 1e3).toFixed(1)} k`;
  return String(Math.round(n));
}

function fmtMetric(v) {
  if (v == null) return "–";
  if (Math.abs(v) >= 1e4 || Number.isInteger(v)) return fmtCount(v);
  return v.toFixed(2);
}

function fmtTime(s) {
  const h = Math.floor(s / 3600);
  const m = Math.floor((s % 3600) / 60);
  const sec = Math.floor(s % 60);
  return `${h}:${String(m).padStart(2, "0")}:${String(sec).padStart(2, "0")}`;
}

const el = {
  clock: document.getElementById("sim-clock"),
  vehicleCount: document.getElementById("vehicle-count"),
  sessionCount: document.getElementById("session-count"),
  fps: document.getElementById("fps"),
  sessions: document.getElementById("sessions-body"),
  sessionsNote: document.getElementById("sessions-note"),
  locks: document.getElementById("locks-body"),
  nodes: document.getElementById("nodes-body"),
  metrics: document.getElementById("metrics-list"),
  metricsMore: document.getElementById("metrics-more"),
  pause: document.getElementById("btn-pause"),
  fleetStop: document.getElementById("fleet-stop"),
  resume: document.getElementById("btn-resume"),
};

const metricRows = new Map();

function updatePanels() {
  if (!state.panelsDirty) return;
  state.panelsDirty = false;
  const stop = state.sim.stop || "running";
  const clockNote = stop !== "running" ? ` (${stop})` : state.sim.paused ? " (paused)" : "";
  setText(el.clock, fmtTime(state.now) + clockNote);
  // What the vehicles report, never what was asked: "stopped" once every one stands.
  el.fleetStop.dataset.stop = stop;
  if (stop === "stopped") setText(el.fleetStop, "fleet stopped: every vehicle stands");
  else if (stop === "stopping") {
    const moving = [...state.vehicles.values()].filter((v) => !(v.speed === 0 && (v.held || v.status === "failed")));
    setText(el.fleetStop, `fleet stopping: ${moving.length} vehicle${moving.length === 1 ? "" : "s"} still moving`);
  } else setText(el.fleetStop, "");
  setText(el.vehicleCount, String(state.vehicles.size));
  setText(el.sessionCount, String(state.sessions.size));
  el.pause.classList.toggle("active", state.sim.paused);
  el.resume.classList.toggle("active", !state.sim.paused);
  el.pause.disabled = state.sim.paused;
  el.resume.disabled = !state.sim.paused;
  const speed = String(state.sim.speed);
  if (document.activeElement !== speedSelect && speedSelect.value !== speed) {
    if (![...speedSelect.options].some((o) => o.value === speed)) {
      speedSelect.add(new Option(`${speed}×`, speed));
    }
    speedSelect.value = speed;
  }

  // Sessions started over the API first, then the newest.
  const sessions = [...state.sessions.values()].sort(
    (a, b) => Number(Boolean(b.via_api)) - Number(Boolean(a.via_api)) || b.started_at - a.started_at || (a.id < b.id ? -1 : 1),
  );
  const shown = sessions.slice(0, MAX_SESSION_ROWS);
  setText(el.sessionsNote, sessions.length > shown.length ? `(${shown.length} of ${sessions.length} shown)` : `(${sessions.length} live)`);
  syncRows(
    el.sessions,
    shown.map((s) => ({ key: s.id, s })),
    "data-session-id",
    ({ s }) => [
      { text: s.id },
      { text: `${s.role} → ${s.participant_role}` },
      { text: s.node },
      { text: `${s.members.length}: ${s.members.join(" ")}`, cls: "members", attr: { "data-members": s.members.join(" ") } },
      { text: `${Math.max(0, state.now - s.started_at).toFixed(1)} s` },
    ],
    (row, { s }) => {
      row.classList.toggle("via-api", Boolean(s.via_api));
      row.classList.toggle("selected", s.id === selectedSession);
    },
  );

  const vehicles = [...state.vehicles.values()].sort((a, b) => (a.id < b.id ? -1 : a.id > b.id ? 1 : 0));
  syncRows(
    el.locks,
    vehicles.map((v) => ({ key: v.id, v })),
    "data-vehicle-id",
    ({ v }) => [
      { text: v.id },
      { text: v.status },
      { text: String(v.locked.length) },
      { text: String(v.requested.length) },
      { text: v.hull_length.toFixed(2) },
    ],
  );

  const nodes = [...state.nodes.entries()].sort((a, b) => (a[0] < b[0] ? -1 : a[0] > b[0] ? 1 : 0));
  syncRows(
    el.nodes,
    nodes.map(([id, n]) => ({ key: id, n })),
    "data-node-id",
    ({ key, n }) => [{ text: key }, { text: fmtCount(n.messages) }, { text: fmtCount(n.bytes) }],
  );

  for (const [k, v] of Object.entries(state.metrics).sort()) {
    let row = metricRows.get(k);
    if (!row) {
      const dt = document.createElement("dt");
      const dd = document.createElement("dd");
      dt.textContent = k.replaceAll("_", " ");
      dd.setAttribute("data-metric", k);
      (KEY_METRICS.includes(k) ? el.metrics : el.metricsMore).append(dt, dd);
      row = dd;
      metricRows.set(k, dd);
    }
    setText(row, fmtMetric(v));
  }
}

// ---- charts -------------------------------------------------------------------------------

const charts = {
  tasks: { canvas: document.getElementById("chart-tasks"), values: [], color: "#2ecc71" },
  messages: { canvas: document.getElementById("chart-messages"), values: [], color: "#4aa3ff" },
  lastMessages: null,
  lastNow: null,
};

function resetCharts() {
  charts.tasks.values = [];
  charts.messages.values = [];
  charts.lastMessages = null;
  charts.lastNow = null;
}

function sampleCharts() {
  const m = state.metrics;
  let perHour = m.tasks_per_hour;
  if (perHour == null && m.tasks_completed != null && state.now > 0) perHour = (m.tasks_completed / state.now) * 3600;
  if (perHour != null) push(charts.tasks, perHour);
  // Without a fleet-wide figure, count what the nodes sent.
  let messages = m.messages;
  if (messages == null && state.nodes.size > 0) {
    messages = 0;
    for (const n of state.nodes.values()) messages += n.sent || 0;
  }
  if (messages != null) {
    if (charts.lastMessages != null && state.now > charts.lastNow) {
      push(charts.messages, (messages - charts.lastMessages) / (state.now - charts.lastNow));
    }
    if (charts.lastNow == null || state.now !== charts.lastNow) {
      charts.lastMessages = messages;
      charts.lastNow = state.now;
    }
  }
  drawChart(charts.tasks);
  drawChart(charts.messages);
}

function push(chart, value) {
  chart.values.push(value);
  if (chart.values.length > CHART_SAMPLES) chart.values.shift();
}

function drawChart(chart) {
  const c = chart.canvas;
  const dpr = window.devicePixelRatio || 1;
  const w = c.clientWidth || c.width;
  const h = c.clientHeight || c.height;
  if (c.width !== Math.round(w * dpr)) {
    c.width = Math.round(w * dpr);
    c.height = Math.round(h * dpr);
  }
  const g = c.getContext("2d");
  g.setTransform(dpr, 0, 0, dpr, 0, 0);
  g.clearRect(0, 0, w, h);
  const values = chart.values;
  if (values.length === 0) return;
  const max = Math.max(1e-9, ...values) * 1.15;
  g.beginPath();
  values.forEach((v, i) => {
    const x = (i / (CHART_SAMPLES - 1)) * w;
    const y = h - 4 - (v / max) * (h - 16);
    if (i === 0) g.moveTo(x, y);
    else g.lineTo(x, y);
  });
  g.strokeStyle = chart.color;
  g.lineWidth = 1.5;
  g.stroke();
  g.fillStyle = "#d6dde5";
  g.font = "11px system-ui, sans-serif";
  g.textBaseline = "top";
  g.fillText(fmtCount(values[values.length - 1]), 4, 2);
}

// ---- main loop ------------------------------------------------------------------------------

const fpsMeter = { frames: 0, since: performance.now(), value: 0, total: 0 };

function loop(nowMs) {
  drawFrame(nowMs);
  fpsMeter.frames++;
  fpsMeter.total++;
  if (nowMs - fpsMeter.since >= 1000) {
    fpsMeter.value = (fpsMeter.frames * 1000) / (nowMs - fpsMeter.since);
    fpsMeter.frames = 0;
    fpsMeter.since = nowMs;
    setText(el.fps, fpsMeter.value.toFixed(0));
  }
  requestAnimationFrame(loop);
}

// ---- test and debugging hooks (documented in docs/dashboard.md) -----------------------------

window.__dashboard = {
  /** True once the first snapshot arrived. */
  get ready() {
    return state.layout !== null;
  },
  /** Frames drawn so far, and the frame rate over the last second. */
  get frames() {
    return fpsMeter.total;
  },
  get fps() {
    return fpsMeter.value;
  },
  /** Feed messages received so far. */
  get messages() {
    return state.messages;
  },
  /** Simulated time of the newest message. */
  get now() {
    return state.now;
  },
  /** The last task created by clicking a station: {id, station} or null. */
  get lastTask() {
    return state.lastTask;
  },
  stationIds() {
    return state.layout ? state.layout.stations.map((s) => s.id) : [];
  },
  /** Viewport (client) coordinates of a station's centre, for mouse.click; null if unknown. */
  stationScreenPosition(id) {
    const st = state.stationsById.get(id);
    if (!st) return null;
    const rect = canvas.getBoundingClientRect();
    const [sx, sy] = toScreen(st.x, st.y);
    return { x: rect.left + sx, y: rect.top + sy };
  },
  /** {id: [x, y, status, task]} of every AGV in world coordinates. */
  vehicles() {
    const out = {};
    for (const v of state.vehicles.values()) out[v.id] = [v.x, v.y, v.status, v.task];
    return out;
  },
  /** {id: [speed, held]} of every AGV, as it reports them. */
  motion() {
    const out = {};
    for (const v of state.vehicles.values()) out[v.id] = [v.speed, v.held];
    return out;
  },
  /** {id: members} of every live session. */
  sessions() {
    const out = {};
    for (const s of state.sessions.values()) out[s.id] = [...s.members];
    return out;
  },
  fit: fitView,
  /** Viewport (client) coordinates of a world point. */
  screenPosition(x, y) {
    const rect = canvas.getBoundingClientRect();
    const [sx, sy] = toScreen(x, y);
    return { x: rect.left + sx, y: rect.top + sy };
  },
  /** Viewport coordinates of an AGV's centre as drawn now, or null. */
  vehicleScreenPosition(id) {
    const v = state.vehicles.get(id);
    if (!v) return null;
    const [dx, dy] = drawnOffset(v, interpolation(performance.now()));
    return this.screenPosition(v.x + dx, v.y + dy);
  },
  /** Draw `fn(ctx, {px, position})` in world coordinates on every frame, above the fleet. */
  addOverlay(fn) {
    overlays.push(fn);
  },
};

new ResizeObserver(() => resize()).observe(canvas);
resize();
connect();
setInterval(updatePanels, PANEL_INTERVAL_MS);
setInterval(sampleCharts, CHART_INTERVAL_MS);
setInterval(refreshSessionDetail, 1000);
requestAnimationFrame(loop);
