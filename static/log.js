// The log panel: GET /api/events once a second; active alarms on top, then the latest
// events, newest first. Hooks: #log-panel, #alarms li[data-alarm-key], #events-body
// tr[data-seq] with td[data-severity].

const REFRESH_MS = 1000;
const SHOWN = 80;

const alarmsList = document.getElementById("alarms");
const eventsBody = document.getElementById("events-body");
const note = document.getElementById("log-note");

function fmtTime(s) {
  const m = Math.floor(s / 60);
  const sec = (s % 60).toFixed(1).padStart(4, "0");
  return `${m}:${sec}`;
}

function renderAlarms(alarms) {
  const existing = new Map([...alarmsList.children].map((li) => [li.dataset.alarmKey, li]));
  let ref = alarmsList.firstElementChild;
  for (const alarm of alarms) {
    let li = existing.get(alarm.key);
    existing.delete(alarm.key);
    if (!li) {
      li = document.createElement("li");
      li.dataset.alarmKey = alarm.key;
    }
    li.className = `alarm ${alarm.severity}`;
    const text = `${fmtTime(alarm.since)}  ${alarm.text}`;
    if (li.textContent !== text) li.textContent = text;
    if (li === ref) ref = ref.nextElementSibling;
    else alarmsList.insertBefore(li, ref);
  }
  for (const li of existing.values()) li.remove();
  alarmsList.hidden = alarms.length === 0;
}

function renderEvents(events) {
  const shown = events.slice(-SHOWN).reverse();
  const existing = new Map([...eventsBody.children].map((r) => [r.dataset.seq, r]));
  let ref = eventsBody.firstElementChild;
  for (const event of shown) {
    const key = String(event.seq);
    let row = existing.get(key);
    existing.delete(key);
    if (!row) {
      row = document.createElement("tr");
      row.dataset.seq = key;
      const cells = [fmtTime(event.time), event.severity, event.source, event.text];
      for (const text of cells) {
        const td = document.createElement("td");
        td.textContent = text;
        row.append(td);
      }
      row.children[1].dataset.severity = event.severity;
      row.children[1].className = `severity ${event.severity}`;
      row.children[3].className = "text";
    }
    if (row === ref) ref = ref.nextElementSibling;
    else eventsBody.insertBefore(row, ref);
  }
  for (const row of existing.values()) row.remove();
}

async function refresh() {
  try {
    const response = await fetch(`/api/events?limit=${SHOWN}`);
    if (!response.ok) return;
    const body = await response.json();
    renderAlarms(body.alarms);
    renderEvents(body.events);
    note.textContent = body.alarms.length ? `(${body.alarms.length} active)` : "";
  } catch {
    // The feed's status shows a lost server; the next refresh tries again.
  }
}

refresh();
setInterval(refresh, REFRESH_MS);
