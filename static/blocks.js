// Closed parts of the floor: GET /api/blocks once a second, drawn on the floor plan
// (closed paths thick and dashed, closed points crossed, a closed polygon shaded), and a
// panel to close a segment, a point or a polygon (POST /api/blocks) and to reopen one
// (DELETE /api/blocks/{id}). Hooks: #blocks-panel, rows tr[data-block-id],
// #blocks-status; window.__blocksPanel = {ids, drawnSegments}.

import { loginEnded } from "./access.js";

const REFRESH_MS = 1000;
const COLOR = "#ff5a36";
const SHADE = "rgba(255, 90, 54, 0.18)";

const body = document.getElementById("blocks-body");
const form = document.getElementById("blocks-form");
const kind = document.getElementById("blocks-kind");
const what = document.getElementById("blocks-what");
const reason = document.getElementById("blocks-reason");
const force = document.getElementById("blocks-force");
const status = document.getElementById("blocks-status");

const shown = { blocks: [], drawnSegments: [] };

function say(text, isError = false) {
  status.textContent = text;
  status.className = isError ? "status error" : "status";
}

// "x y, x y, x y" (or "x,y; x,y; ...") as [[x, y], ...]; null if it is not that.
function vertices(text) {
  const numbers = text.split(/[\s,;]+/).filter((t) => t !== "").map(Number);
  if (numbers.length < 6 || numbers.length % 2 || numbers.some((n) => !Number.isFinite(n))) return null;
  const out = [];
  for (let i = 0; i < numbers.length; i += 2) out.push([numbers[i], numbers[i + 1]]);
  return out;
}

function describe(block) {
  return typeof block.what === "string" ? block.what : `${block.what.length} vertices`;
}

function render(blocks) {
  const rows = blocks.map((block) => {
    const tr = document.createElement("tr");
    tr.dataset.blockId = block.id;
    for (const text of [block.id, block.kind, describe(block), block.reason]) {
      const td = document.createElement("td");
      td.textContent = text;
      tr.append(td);
    }
    const td = document.createElement("td");
    const button = document.createElement("button");
    button.type = "button";
    button.textContent = "Reopen";
    button.title = `reopen ${block.id}`;
    button.addEventListener("click", () => reopen(block.id));
    td.append(button);
    tr.append(td);
    return tr;
  });
  body.replaceChildren(...rows);
}

async function refresh() {
  let response;
  try {
    response = await fetch("/api/blocks");
  } catch {
    return;
  }
  if (loginEnded(response)) return;
  const data = await response.json().catch(() => null);
  if (!response.ok || !data) return;
  document.getElementById("blocks-panel").hidden = !data.closable;
  const before = JSON.stringify(shown.blocks);
  shown.blocks = data.blocks;
  if (JSON.stringify(data.blocks) !== before) render(data.blocks);
}

async function change(url, options, done) {
  let response;
  try {
    response = await fetch(url, options);
  } catch (err) {
    say(`cannot reach the server: ${err.message}`, true);
    return;
  }
  if (loginEnded(response)) return;
  const data = await response.json().catch(() => null);
  if (response.ok) {
    say(done(data));
    refresh();
  } else {
    say(data && data.detail ? data.detail : `error ${response.status}`, true);
  }
}

function close(event) {
  event.preventDefault();
  const text = what.value.trim();
  const polygon = kind.value === "polygon";
  const target = polygon ? vertices(text) : text;
  if (!target) {
    say(polygon ? "a polygon: at least three vertices, x y, x y, x y" : "name what to close", true);
    return;
  }
  const payload = { kind: kind.value, what: target, force: force.checked };
  if (reason.value.trim()) payload.reason = reason.value.trim();
  change(
    "/api/blocks",
    { method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(payload) },
    (block) => `closed ${block.id}: ${block.segments.length} paths, ${block.points.length} points`,
  );
}

function reopen(id) {
  change(`/api/blocks/${encodeURIComponent(id)}`, { method: "DELETE" }, () => `reopened ${id}`);
}

function draw(ctx, { px }) {
  const drawn = [];
  ctx.fillStyle = SHADE;
  for (const block of shown.blocks) {
    if (block.kind !== "polygon") continue;
    ctx.beginPath();
    block.what.forEach(([x, y], i) => (i ? ctx.lineTo(x, y) : ctx.moveTo(x, y)));
    ctx.closePath();
    ctx.fill();
  }
  ctx.strokeStyle = COLOR;
  ctx.lineCap = "round";
  ctx.lineWidth = 6 * px;
  ctx.setLineDash([8 * px, 5 * px]);
  ctx.beginPath();
  for (const block of shown.blocks) {
    block.polylines.forEach((line, i) => {
      if (line.length < 2) return;
      line.forEach(([x, y], k) => (k ? ctx.lineTo(x, y) : ctx.moveTo(x, y)));
      drawn.push(block.segments[i]);
    });
  }
  ctx.stroke();
  ctx.setLineDash([]);
  ctx.lineWidth = 2.5 * px;
  ctx.beginPath();
  const r = 6 * px;
  for (const block of shown.blocks) {
    for (const [x, y] of block.positions) {
      ctx.moveTo(x - r, y - r);
      ctx.lineTo(x + r, y + r);
      ctx.moveTo(x - r, y + r);
      ctx.lineTo(x + r, y - r);
    }
  }
  ctx.stroke();
  shown.drawnSegments = drawn;
}

form.addEventListener("submit", close);

function whenReady() {
  if (window.__dashboard && window.__dashboard.addOverlay) window.__dashboard.addOverlay(draw);
  else setTimeout(whenReady, 50);
}
whenReady();
refresh();
setInterval(refresh, REFRESH_MS);

window.__blocksPanel = {
  /** The ids of the blocks in force, as last fetched. */
  get ids() {
    return shown.blocks.map((b) => b.id);
  },
  /** The closed segments drawn on the last frame. */
  get drawnSegments() {
    return [...shown.drawnSegments];
  },
};
