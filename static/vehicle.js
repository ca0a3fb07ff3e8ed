// The vehicle panel: click an AGV on the floor plan (app.js sends "vehicle-select") and
// GET /api/vehicles/{id}/detail twice a second shows its status, task, route, locks,
// wait, sessions and traffic; the rest of its route is drawn on the map while selected.
// Opened, #vehicle-space-box lists what the AGV's tuplespace holds (its locks live
// there): GET /api/nodes/{id}/space, the first SPACE_LIMIT tuples, with each refresh.
// The buttons of #vehicle-actions (Stop, Resume, Out of service, In service, Send home) POST to
// /api/vehicles/{id}/<action>; the facts show what the vehicle then reports.
// Hooks: #vehicle-panel, #vehicle-id, #vehicle-facts dd[data-fact], #vehicle-initiated,
// #vehicle-participating, #vehicle-traffic, #vehicle-close, #vehicle-status,
// #vehicle-actions button[data-action], and window.__vehiclePanel.

const REFRESH_MS = 500;
const SPACE_LIMIT = 50;
// One colour for the drawing and the legend's swatch: the page's --route.
const ROUTE_COLOR = getComputedStyle(document.documentElement).getPropertyValue("--route").trim() || "#c6ff00";

const panel = document.getElementById("vehicle-panel");
const idLabel = document.getElementById("vehicle-id");
const facts = document.getElementById("vehicle-facts");
const initiated = document.getElementById("vehicle-initiated");
const participating = document.getElementById("vehicle-participating");
const traffic = document.getElementById("vehicle-traffic");
const status = document.getElementById("vehicle-status");
const spaceBox = document.getElementById("vehicle-space-box");
const spaceList = document.getElementById("vehicle-space");
const spaceNote = document.getElementById("vehicle-space-note");

const selection = { id: null, detail: null, drawnPoints: 0, generation: 0 };

function say(text, isError = false) {
  if (status.textContent !== text) status.textContent = text;
  status.className = isError ? "status error" : "status";
}

function fmtSeconds(s) {
  return s == null ? "–" : `${s.toFixed(1)} s`;
}

function fmtCount(n) {
  if (n == null) return "–";
  if (n >= 1e6) return `${(n / 1e6).toFixed(2)} M`;
  if (n >= 1e4) return `${(n / 1e3).toFixed(1)} k`;
  return String(n);
}

function fmtPoint(p) {
  return p ? `(${p[0].toFixed(1)}, ${p[1].toFixed(1)})` : "–";
}

// One <dt>/<dd> pair per fact, created once and patched in place.
function setFact(key, label, text) {
  let dd = facts.querySelector(`dd[data-fact="${key}"]`);
  if (!dd) {
    const dt = document.createElement("dt");
    dt.textContent = label;
    dd = document.createElement("dd");
    dd.dataset.fact = key;
    facts.append(dt, dd);
  }
  if (dd.textContent !== text) dd.textContent = text;
}

function fillTable(tbody, rows, keyOf) {
  const existing = new Map([...tbody.children].map((r) => [r.dataset.key, r]));
  let ref = tbody.firstElementChild;
  for (const cells of rows) {
    const key = keyOf(cells);
    let row = existing.get(key);
    existing.delete(key);
    if (!row) {
      row = document.createElement("tr");
      row.dataset.key = key;
      for (let i = 0; i < cells.length; i++) row.append(document.createElement("td"));
    }
    cells.forEach((text, i) => {
      if (row.children[i].textContent !== text) row.children[i].textContent = text;
    });
    if (row === ref) ref = ref.nextElementSibling;
    else tbody.insertBefore(row, ref);
  }
  for (const row of existing.values()) row.remove();
}

function render(d) {
  idLabel.textContent = d.id;
  setFact("status", "status", d.status);
  setFact("task", "task", d.task ?? "–");
  setFact("position", "position", fmtPoint([d.x, d.y]));
  setFact(
    "route",
    "route left",
    d.route.length ? `${d.route_length.toFixed(1)} m to ${fmtPoint(d.destination)}` : "at rest",
  );
  setFact("locks", "locks", `${d.locked.length} locked, ${d.requested.length} requested`);
  setFact("hull", "hull length", `${d.hull_length.toFixed(2)} m`);
  const speed = d.speed == null ? "–" : `${d.speed.toFixed(2)} m/s`;
  setFact("motion", "motion", d.held ? `${speed}, held (stopped by the operator)` : speed);
  setFact("service", "service", d.in_service === false ? "out of service" : "in service");
  setFact("battery", "battery", d.battery == null ? "–" : `${d.battery.toFixed(1)} %`);
  const w = d.wait;
  setFact("wait", "wait", w.waiting ? `${fmtSeconds(w.seconds)} (since ${fmtSeconds(w.since)})` : "not waiting");
  const t = d.traffic;
  setFact("sent", "sent", t ? `${fmtCount(t.frames_sent)} frames, ${fmtCount(t.bytes_sent)} B` : "no node");
  setFact(
    "received",
    "received",
    t ? `${fmtCount(t.frames_received)} frames, ${fmtCount(t.bytes_received)} B` : "no node",
  );
  fillTable(
    initiated,
    d.initiated.map((s) => [s.id, `${s.role} → ${s.participant_role}`, String(s.members.length), fmtSeconds(s.age_s)]),
    (cells) => cells[0],
  );
  fillTable(
    participating,
    d.participating.map((p) => [p.session_id, p.initiator, p.role, fmtSeconds(p.age_s)]),
    (cells) => cells[0],
  );
  const kinds = t ? [...new Set([...Object.keys(t.sent), ...Object.keys(t.received)])].sort() : [];
  fillTable(
    traffic,
    kinds.map((k) => {
      const [sn, sb] = t.sent[k] ?? [0, 0];
      const [rn, rb] = t.received[k] ?? [0, 0];
      return [k, fmtCount(sn), fmtCount(sb), fmtCount(rn), fmtCount(rb)];
    }),
    (cells) => cells[0],
  );
}

async function refresh() {
  const id = selection.id;
  if (!id) return;
  const generation = selection.generation;
  let response;
  try {
    response = await fetch(`/api/vehicles/${encodeURIComponent(id)}/detail`);
  } catch (err) {
    say(`cannot reach the server: ${err.message}`, true);
    return;
  }
  if (generation !== selection.generation) return; // another AGV was picked meanwhile
  const data = await response.json().catch(() => null);
  if (response.ok && data) {
    selection.detail = data;
    render(data);
    say("");
    if (spaceBox.open) refreshSpace(id, generation);
  } else {
    selection.detail = null;
    say(data && data.detail ? `${id}: ${data.detail}` : `${id}: ${response.status}`, true);
  }
}

// What the AGV's node's tuplespace holds; a node in another process says why not.
async function refreshSpace(id, generation) {
  let response;
  try {
    response = await fetch(`/api/nodes/${encodeURIComponent(id)}/space?limit=${SPACE_LIMIT}`);
  } catch {
    return;
  }
  const data = await response.json().catch(() => null);
  if (generation !== selection.generation) return;
  if (!response.ok || !data) {
    spaceList.replaceChildren();
    spaceNote.textContent = data && data.detail ? data.detail : String(response.status);
    return;
  }
  const shown = data.tuples.length;
  spaceNote.textContent = shown < data.total ? `${shown} of ${data.total} tuples` : `${data.total} tuples`;
  const texts = data.tuples.map((t) => JSON.stringify(t));
  if (texts.join("\n") === [...spaceList.children].map((li) => li.textContent).join("\n")) return;
  spaceList.replaceChildren(
    ...texts.map((text) => {
      const li = document.createElement("li");
      li.textContent = text;
      return li;
    }),
  );
}

spaceBox.addEventListener("toggle", () => {
  if (spaceBox.open && selection.id) refreshSpace(selection.id, selection.generation);
});

// Ask the fleet to stop, resume, take out of or bring into service the selected AGV.
async function act(action) {
  const id = selection.id;
  if (!id) return;
  let response;
  try {
    response = await fetch(`/api/vehicles/${encodeURIComponent(id)}/${action}`, {
      method: "POST",
      headers: { "Content-Type": "application/json" },
      body: "{}",
    });
  } catch (err) {
    say(`request failed: ${err.message}`, true);
    return;
  }
  let data = null;
  try {
    data = await response.json();
  } catch {
    data = null;
  }
  if (!response.ok) {
    say(`${action}: ${data && data.detail ? data.detail : response.status}`, true);
    return;
  }
  say(`${id}: ${action.replaceAll("-", " ")} asked`); // the facts show what it reports
}

for (const button of document.querySelectorAll("#vehicle-actions button[data-action]")) {
  button.addEventListener("click", () => act(button.dataset.action));
}

function select(id) {
  selection.id = id;
  selection.detail = null;
  selection.generation++;
  facts.replaceChildren();
  for (const tbody of [initiated, participating, traffic]) tbody.replaceChildren();
  spaceList.replaceChildren();
  spaceNote.textContent = "";
  say(id ? "loading…" : "");
  panel.hidden = !id;
  if (id) {
    idLabel.textContent = id;
    panel.scrollIntoView({ block: "nearest" });
    refresh();
  }
}

// The rest of the route from where the AGV is drawn now, a ring around it, a dot at the end.
function drawRoute(ctx, { px, position }) {
  selection.drawnPoints = 0;
  const d = selection.detail;
  if (!d || d.id !== selection.id) return;
  const here = position(d.id);
  if (!here) return;
  ctx.strokeStyle = ROUTE_COLOR;
  ctx.fillStyle = ROUTE_COLOR;
  ctx.lineWidth = 3 * px;
  ctx.beginPath();
  ctx.arc(here[0], here[1], Math.max(d.length, d.width) * 0.75, 0, Math.PI * 2);
  ctx.stroke();
  if (d.route.length < 2) return;
  ctx.beginPath();
  ctx.moveTo(here[0], here[1]);
  for (const [x, y] of d.route.slice(1)) ctx.lineTo(x, y);
  ctx.stroke();
  const [ex, ey] = d.route[d.route.length - 1];
  ctx.beginPath();
  ctx.arc(ex, ey, 5 * px, 0, Math.PI * 2);
  ctx.fill();
  selection.drawnPoints = d.route.length;
}

document.addEventListener("vehicle-select", (event) => select(event.detail));
document.getElementById("vehicle-close").addEventListener("click", () => select(null));

function whenReady() {
  if (window.__dashboard && window.__dashboard.addOverlay) window.__dashboard.addOverlay(drawRoute);
  else setTimeout(whenReady, 50);
}
whenReady();
setInterval(refresh, REFRESH_MS);

window.__vehiclePanel = {
  /** The selected AGV's id, or null. */
  get selected() {
    return selection.id;
  },
  /** The last detail fetched for it (GET /api/vehicles/{id}/detail), or null. */
  get detail() {
    return selection.detail;
  },
  /** Route points drawn on the last frame (0: no route drawn). */
  get drawnPoints() {
    return selection.drawnPoints;
  },
  select,
};
