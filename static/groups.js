// The groups panel. Pick a session: its members now and its joins and leaves
// (GET /api/membership, GET /api/membership/{id}). Type a group definition: the live
// view_group from a chosen node (GET /api/groups/view, once a second while shown), its
// members ringed on the map. Hooks: #groups-session, #groups-session-note,
// #groups-history tr[data-change], #groups-node, #groups-template, #groups-definition,
// #groups-show, #groups-clear, #groups-status, and window.__groupsPanel.

const REFRESH_MS = 1000;
const LIST_MS = 2000;
const NODES_MS = 10000;
const HISTORY_ROWS = 100;
// One colour for the drawing and the legend's swatch: the page's --group.
const GROUP_COLOR = getComputedStyle(document.documentElement).getPropertyValue("--group").trim() || "#ffffff";

const TEMPLATES = {
  circles_overlap: { type: "circles_overlap", position: "position", radius: "hull_length" },
  within: { type: "within", distance: 20, position: "position" },
  near: { type: "near", point: [20, 15], distance: 15, position: "position" },
  property_equals: { type: "property_equals", name: "status", value: "idle" },
  and: {
    type: "and",
    of: [{ type: "within", distance: 30 }, { type: "property_equals", name: "status", value: "idle" }],
  },
  or: {
    type: "or",
    of: [{ type: "circles_overlap" }, { type: "property_equals", name: "status", value: "busy" }],
  },
};

const sessionSelect = document.getElementById("groups-session");
const sessionNote = document.getElementById("groups-session-note");
const history = document.getElementById("groups-history");
const nodeSelect = document.getElementById("groups-node");
const template = document.getElementById("groups-template");
const definition = document.getElementById("groups-definition");
const showButton = document.getElementById("groups-show");
const clearButton = document.getElementById("groups-clear");
const status = document.getElementById("groups-status");

const live = { definition: null, node: null, members: [], drawn: 0, history: null };

function say(text, isError = false) {
  if (status.textContent !== text) status.textContent = text;
  status.className = isError ? "status error" : "status";
}

async function getJson(url) {
  const response = await fetch(url);
  const data = await response.json().catch(() => null);
  return { ok: response.ok, status: response.status, data };
}

function syncOptions(select, items, keep) {
  const wanted = items.map(([value, label]) => `${value}\u0000${label}`).join("\u0001");
  if (select.dataset.options === wanted) return;
  const chosen = select.value;
  select.replaceChildren(...items.map(([value, label]) => new Option(label, value)));
  select.dataset.options = wanted;
  if (keep && items.some(([value]) => value === chosen)) select.value = chosen;
}

// ---- session members and their history -----------------------------------------------

async function refreshSessions() {
  let answer;
  try {
    answer = await getJson("/api/membership?limit=100");
  } catch {
    return; // the header shows a lost server
  }
  if (!answer.ok) return;
  const items = [["", "(pick one)"]];
  const chosen = sessionSelect.value;
  let chosenListed = false;
  for (const s of answer.data) {
    chosenListed ||= s.id === chosen;
    items.push([s.id, `${s.id} ${s.role}${s.ended_at == null ? "" : " (ended)"}`]);
  }
  // A picked session that fell off the list stays picked: its history is still asked for.
  if (chosen && !chosenListed) items.push([chosen, `${chosen} (older)`]);
  syncOptions(sessionSelect, items, true);
}

async function refreshHistory() {
  const id = sessionSelect.value;
  if (!id) {
    live.history = null;
    sessionNote.textContent = "";
    history.replaceChildren();
    return;
  }
  let answer;
  try {
    answer = await getJson(`/api/membership/${encodeURIComponent(id)}`);
  } catch {
    return;
  }
  if (sessionSelect.value !== id) return;
  if (!answer.ok) {
    live.history = null;
    sessionNote.textContent = answer.data && answer.data.detail ? answer.data.detail : `error ${answer.status}`;
    history.replaceChildren();
    return;
  }
  const h = answer.data;
  live.history = h;
  const state = h.ended_at == null ? "live" : `ended at ${h.ended_at.toFixed(1)} s`;
  const older = h.dropped ? `, ${h.dropped} older changes not kept` : "";
  sessionNote.textContent =
    `${h.node} (${h.role} → ${h.participant_role}), ${state}; members now: ` +
    `${h.members.length ? h.members.join(" ") : "none"}; ${h.joins} joins, ${h.leaves} leaves${older}`;
  sessionNote.dataset.members = h.members.join(" ");
  const rows = h.changes.slice(-HISTORY_ROWS).reverse();
  history.replaceChildren(
    ...rows.map((c) => {
      const tr = document.createElement("tr");
      tr.dataset.change = c.change;
      for (const text of [`${c.time.toFixed(1)} s`, c.node, c.change]) {
        const td = document.createElement("td");
        td.textContent = text;
        tr.append(td);
      }
      return tr;
    }),
  );
}

// ---- the live group view -------------------------------------------------------------

async function refreshNodes() {
  let answer;
  try {
    answer = await getJson("/api/nodes");
  } catch {
    return;
  }
  if (!answer.ok) return;
  const ids = answer.data.map((n) => n.id);
  const agvs = ids.filter((id) => id.startsWith("agv"));
  const others = ids.filter((id) => !id.startsWith("agv"));
  const first = nodeSelect.options.length === 0;
  syncOptions(nodeSelect, [...agvs, ...others].map((id) => [id, id]), true);
  if (first && agvs.length) nodeSelect.value = agvs[0];
}

function parseDefinition() {
  try {
    return JSON.parse(definition.value);
  } catch (err) {
    say(`the definition is not JSON: ${err.message}`, true);
    return null;
  }
}

async function refreshView() {
  if (!live.definition) return;
  const { definition: text, node } = live;
  const query = new URLSearchParams({ definition: text });
  if (node) query.set("node", node);
  let answer;
  try {
    answer = await getJson(`/api/groups/view?${query}`);
  } catch (err) {
    say(`cannot reach the server: ${err.message}`, true);
    return;
  }
  if (live.definition !== text || live.node !== node) return; // changed meanwhile
  if (!answer.ok) {
    live.members = [];
    live.definition = null;
    clearButton.disabled = true;
    say(answer.data && answer.data.detail ? answer.data.detail : `error ${answer.status}`, true);
    return;
  }
  live.members = answer.data.members;
  const list = live.members.length ? live.members.join(" ") : "none";
  say(`${live.members.length} in the group from ${answer.data.node}: ${list}`);
}

function show() {
  const parsed = parseDefinition();
  if (parsed === null) {
    // The map must not go on showing a group for a definition no longer typed.
    live.definition = null;
    live.members = [];
    clearButton.disabled = true;
    return;
  }
  live.definition = JSON.stringify(parsed);
  live.node = nodeSelect.value || null;
  live.members = [];
  clearButton.disabled = false;
  say("asking…");
  refreshView();
}

function clear() {
  live.definition = null;
  live.members = [];
  clearButton.disabled = true;
  say("");
}

// Members ringed where they are drawn now, and the viewpoint node marked.
function drawGroup(ctx, { px, position }) {
  live.drawn = 0;
  if (!live.definition) return;
  ctx.strokeStyle = GROUP_COLOR;
  ctx.lineWidth = 2.5 * px;
  ctx.beginPath();
  for (const id of live.members) {
    const at = position(id);
    if (!at) continue;
    ctx.moveTo(at[0] + 14 * px, at[1]);
    ctx.arc(at[0], at[1], 14 * px, 0, Math.PI * 2);
    live.drawn++;
  }
  ctx.stroke();
  const from = live.node ? position(live.node) : null;
  if (from) {
    ctx.setLineDash([3 * px, 3 * px]);
    ctx.beginPath();
    ctx.arc(from[0], from[1], 18 * px, 0, Math.PI * 2);
    ctx.stroke();
  }
}

template.addEventListener("change", () => {
  definition.value = JSON.stringify(TEMPLATES[template.value]);
});
sessionSelect.addEventListener("change", refreshHistory);
// A click on a row of the sessions panel picks that session here too.
document.getElementById("sessions-body").addEventListener("click", (event) => {
  const row = event.target.closest("tr[data-session-id]");
  if (!row) return;
  const id = row.getAttribute("data-session-id");
  if (![...sessionSelect.options].some((o) => o.value === id)) sessionSelect.add(new Option(id, id));
  sessionSelect.value = id;
  refreshHistory();
});
nodeSelect.addEventListener("change", () => {
  if (live.definition) show();
});
showButton.addEventListener("click", show);
clearButton.addEventListener("click", clear);
definition.value = JSON.stringify(TEMPLATES[template.value]);

function whenReady() {
  if (window.__dashboard && window.__dashboard.addOverlay) window.__dashboard.addOverlay(drawGroup);
  else setTimeout(whenReady, 50);
}
whenReady();
refreshSessions();
refreshNodes();
setInterval(refreshSessions, LIST_MS);
setInterval(refreshHistory, REFRESH_MS);
setInterval(refreshView, REFRESH_MS);
setInterval(refreshNodes, NODES_MS);

window.__groupsPanel = {
  /** Members of the live group view (empty when none is shown). */
  get members() {
    return [...live.members];
  },
  /** Members ringed on the map on the last frame. */
  get drawn() {
    return live.drawn;
  },
  /** The picked session's last history (GET /api/membership/{id}), or null. */
  get history() {
    return live.history;
  },
};
