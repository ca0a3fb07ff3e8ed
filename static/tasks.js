// The transport-orders panel: GET /api/tasks once a second, newest first; a waiting
// order has a cancel button (DELETE /api/tasks/{id}). Who gave it: the desk, or a
// VDA 5050 master control. Hooks: #tasks-panel, rows tr[data-task-id] with
// td[data-state] and td[data-creator], #tasks-state (filter), #tasks-status.

import { loginEnded } from "./access.js";

const REFRESH_MS = 1000;
const SHOWN = 100;

const body = document.getElementById("tasks-body");
const filter = document.getElementById("tasks-state");
const status = document.getElementById("tasks-status");
const note = document.getElementById("tasks-note");

// A report clears itself after a while; an error stays until the next cancel.
const SAY_CLEAR_MS = 6000;
let sayTimer = null;

function say(text, isError = false) {
  status.textContent = text;
  status.className = isError ? "status error" : "status";
  clearTimeout(sayTimer);
  if (text && !isError) sayTimer = setTimeout(() => say(""), SAY_CLEAR_MS);
}

function fmtSeconds(s) {
  return s == null ? "–" : `${s.toFixed(1)} s`;
}

function cell(row, i, text, attrs = {}) {
  let td = row.children[i];
  if (!td) {
    td = document.createElement("td");
    row.append(td);
  }
  if (td.textContent !== text) td.textContent = text;
  for (const [k, v] of Object.entries(attrs)) if (td.getAttribute(k) !== v) td.setAttribute(k, v);
  return td;
}

function cancelButton(row, task) {
  const td = cell(row, 6, "");
  if (task.state !== "waiting") {
    td.replaceChildren();
    return;
  }
  if (td.querySelector("button")) return;
  const button = document.createElement("button");
  button.type = "button";
  button.className = "cancel";
  button.textContent = "✕";
  button.title = `cancel ${task.id}`;
  button.setAttribute("aria-label", `cancel ${task.id}`);
  button.addEventListener("click", () => cancel(task.id));
  td.replaceChildren(button);
}

function render(tasks) {
  const shown = tasks.slice(-SHOWN).reverse();
  note.textContent = tasks.length > SHOWN ? `(newest ${SHOWN} of ${tasks.length})` : `(${tasks.length})`;
  const existing = new Map([...body.children].map((r) => [r.dataset.taskId, r]));
  let ref = body.firstElementChild;
  for (const task of shown) {
    let row = existing.get(task.id);
    existing.delete(task.id);
    if (!row) {
      row = document.createElement("tr");
      row.dataset.taskId = task.id;
    }
    row.title =
      `created ${fmtSeconds(task.created)}, started ${fmtSeconds(task.started)}, ` +
      `finished ${fmtSeconds(task.finished)}`;
    cell(row, 0, task.id);
    cell(row, 1, task.creator, { "data-creator": task.creator });
    cell(row, 2, task.source);
    cell(row, 3, task.destination);
    // Why it waits for a closed part of the floor ("waits: path P closed"), if it does.
    const state = task.waits ? `${task.state} (${task.waits})` : task.state;
    cell(row, 4, state, { "data-state": task.state, class: `state ${task.state}`, title: task.waits ?? "" });
    cell(row, 5, task.vehicle ?? "–");
    cancelButton(row, task);
    if (row === ref) ref = ref.nextElementSibling;
    else body.insertBefore(row, ref);
  }
  for (const row of existing.values()) row.remove();
}

async function refresh() {
  const query = filter.value ? `?state=${encodeURIComponent(filter.value)}` : "";
  try {
    const response = await fetch(`/api/tasks${query}`);
    if (response.ok) render(await response.json());
  } catch {
    // The feed's status shows a lost server; the next refresh tries again.
  }
}

async function cancel(taskId) {
  let response;
  try {
    response = await fetch(`/api/tasks/${encodeURIComponent(taskId)}`, { method: "DELETE" });
  } catch (err) {
    say(`cancel ${taskId} failed: ${err.message}`, true);
    return;
  }
  if (loginEnded(response)) return;
  const data = await response.json().catch(() => null);
  if (response.ok) say(`task ${taskId} cancelled`);
  else say(data && data.detail ? String(data.detail) : `cancel ${taskId}: ${response.status}`, true);
  refresh();
}

filter.addEventListener("change", refresh);
refresh();
setInterval(refresh, REFRESH_MS);
