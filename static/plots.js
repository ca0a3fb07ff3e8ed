// The plots panel: GET /api/metrics/history every few seconds, drawn by hand on canvas.
// Throughput over time (tasks per hour over the last minute of samples), how long the
// orders waited for a vehicle (histogram), and frames per second by message kind.
// Exports: the same history as CSV or JSON (links with a download attribute).
// Hooks: #plots-panel, canvases #plot-throughput #plot-waits #plot-kinds (each with
// data-points: the points or bars drawn), #export-csv, #export-json, #plots-note;
// window.__plots = {samples, drawn}.

const REFRESH_MS = 2000;
const WINDOW_SAMPLES = 12; // throughput over the last 12 samples (a minute at 5 s)
const MAX_KINDS = 6;
const KIND_COLORS = ["#4aa3ff", "#2ecc71", "#f1c40f", "#e056fd", "#ff8a3d", "#5fd3e6"];
const AXIS = "#7f8c99";
const GRID = "#2a3440";

const canvases = {
  throughput: document.getElementById("plot-throughput"),
  waits: document.getElementById("plot-waits"),
  kinds: document.getElementById("plot-kinds"),
};
const kindLegend = document.getElementById("plot-kinds-legend");
const note = document.getElementById("plots-note");

window.__plots = { samples: 0, drawn: { throughput: 0, waits: 0, kinds: 0 } };

// A canvas sized to its box in device pixels; drawing happens in CSS pixels.
function prepare(canvas) {
  const ratio = window.devicePixelRatio || 1;
  const w = Math.max(1, canvas.clientWidth);
  const h = Math.max(1, canvas.clientHeight);
  if (canvas.width !== Math.round(w * ratio) || canvas.height !== Math.round(h * ratio)) {
    canvas.width = Math.round(w * ratio);
    canvas.height = Math.round(h * ratio);
  }
  const ctx = canvas.getContext("2d");
  ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
  ctx.clearRect(0, 0, w, h);
  ctx.font = "10px system-ui, sans-serif";
  return { ctx, w, h };
}

function shortNumber(v) {
  if (v >= 10000) return `${(v / 1000).toFixed(0)}k`;
  if (v >= 1000) return `${(v / 1000).toFixed(1)}k`;
  if (v >= 100 || Number.isInteger(v)) return v.toFixed(0);
  return v.toFixed(1);
}

function fmtClock(s) {
  const m = Math.floor(s / 60);
  return `${m}:${String(Math.floor(s % 60)).padStart(2, "0")}`;
}

// Axes with the y range and the time range written at their ends; the plot area.
function frame(ctx, w, h, yMax, t0, t1, unit) {
  const area = { x: 30, y: 6, w: w - 36, h: h - 20 };
  ctx.strokeStyle = GRID;
  ctx.lineWidth = 1;
  ctx.beginPath();
  ctx.moveTo(area.x, area.y);
  ctx.lineTo(area.x, area.y + area.h);
  ctx.lineTo(area.x + area.w, area.y + area.h);
  ctx.stroke();
  ctx.fillStyle = AXIS;
  ctx.textAlign = "right";
  ctx.textBaseline = "top";
  ctx.fillText(shortNumber(yMax), area.x - 3, area.y);
  ctx.textBaseline = "bottom";
  ctx.fillText("0", area.x - 3, area.y + area.h);
  ctx.textBaseline = "top";
  ctx.textAlign = "left";
  if (t0 !== null) ctx.fillText(fmtClock(t0), area.x, area.y + area.h + 2);
  ctx.textAlign = "right";
  if (t1 !== null) ctx.fillText(`${fmtClock(t1)} ${unit}`, area.x + area.w, area.y + area.h + 2);
  return area;
}

function emptyText(ctx, w, h, text) {
  ctx.fillStyle = AXIS;
  ctx.textAlign = "center";
  ctx.textBaseline = "middle";
  ctx.fillText(text, w / 2, h / 2);
}

function polyline(ctx, area, points, t0, t1, yMax, color) {
  const span = Math.max(1e-9, t1 - t0);
  ctx.strokeStyle = color;
  ctx.lineWidth = 1.5;
  ctx.beginPath();
  points.forEach(([t, v], i) => {
    const x = area.x + ((t - t0) / span) * area.w;
    const y = area.y + area.h - (Math.min(v, yMax) / yMax) * area.h;
    if (i === 0) ctx.moveTo(x, y);
    else ctx.lineTo(x, y);
  });
  ctx.stroke();
}

// Tasks per hour over a sliding window of samples: what the fleet carries now, where the
// fleet's own tasks_per_hour is the average since the start.
function throughputPoints(samples) {
  const points = [];
  for (let i = 1; i < samples.length; i++) {
    const a = samples[Math.max(0, i - WINDOW_SAMPLES)];
    const b = samples[i];
    const dt = b.time - a.time;
    const done = (b.metrics.tasks_completed ?? NaN) - (a.metrics.tasks_completed ?? NaN);
    if (dt > 0 && Number.isFinite(done)) points.push([b.time, Math.max(0, (done / dt) * 3600)]);
  }
  return points;
}

function drawThroughput(samples) {
  const canvas = canvases.throughput;
  const { ctx, w, h } = prepare(canvas);
  const points = throughputPoints(samples);
  canvas.dataset.points = String(points.length);
  if (points.length < 2) {
    emptyText(ctx, w, h, "collecting samples…");
    return points.length;
  }
  const yMax = Math.max(1, ...points.map((p) => p[1])) * 1.1;
  const t0 = points[0][0];
  const t1 = points[points.length - 1][0];
  const area = frame(ctx, w, h, yMax, t0, t1, "tasks/h");
  polyline(ctx, area, points, t0, t1, yMax, "#2ecc71");
  return points.length;
}

function drawWaits(waits) {
  const canvas = canvases.waits;
  const { ctx, w, h } = prepare(canvas);
  const counts = waits.counts;
  canvas.dataset.points = String(waits.orders);
  if (!waits.orders) {
    emptyText(ctx, w, h, "no order assigned yet");
    return 0;
  }
  const yMax = Math.max(...counts);
  const area = frame(ctx, w, h, yMax, null, null, "");
  const slot = area.w / counts.length;
  ctx.textAlign = "center";
  ctx.textBaseline = "top";
  counts.forEach((n, i) => {
    const bh = (n / yMax) * area.h;
    ctx.fillStyle = "#f1c40f";
    ctx.fillRect(area.x + i * slot + 1, area.y + area.h - bh, Math.max(1, slot - 2), bh);
    ctx.fillStyle = AXIS;
    const edge = waits.edges_s[i];
    const label = i === counts.length - 1 ? `${edge}+` : `${edge}`;
    ctx.fillText(label, area.x + (i + 0.5) * slot, area.y + area.h + 2);
  });
  canvas.title = counts.map((n, i) => `≥ ${waits.edges_s[i]} s: ${n}`).join("\n");
  return counts.length;
}

// Frames per second by kind between consecutive samples, the busiest kinds only.
function kindSeries(samples) {
  const totals = new Map();
  const last = samples[samples.length - 1];
  for (const [kind, n] of Object.entries(last ? last.sent : {})) totals.set(kind, n);
  const kinds = [...totals.entries()].sort((a, b) => b[1] - a[1]).slice(0, MAX_KINDS);
  return kinds.map(([kind]) => {
    const points = [];
    for (let i = 1; i < samples.length; i++) {
      const a = samples[i - 1];
      const b = samples[i];
      const dt = b.time - a.time;
      const dn = (b.sent[kind] ?? 0) - (a.sent[kind] ?? 0);
      if (dt > 0) points.push([b.time, Math.max(0, dn / dt)]);
    }
    return { kind, points };
  });
}

function drawKinds(samples) {
  const canvas = canvases.kinds;
  const { ctx, w, h } = prepare(canvas);
  const series = kindSeries(samples).filter((s) => s.points.length >= 2);
  const drawn = series.reduce((n, s) => n + s.points.length, 0);
  canvas.dataset.points = String(drawn);
  kindLegend.replaceChildren(
    ...series.map((s, i) => {
      const li = document.createElement("li");
      li.dataset.kind = s.kind;
      const sw = document.createElement("i");
      sw.className = "sw";
      sw.style.background = KIND_COLORS[i % KIND_COLORS.length];
      li.append(sw, s.kind);
      return li;
    }),
  );
  if (!series.length) {
    emptyText(ctx, w, h, "collecting samples…");
    return 0;
  }
  const all = series.flatMap((s) => s.points);
  const yMax = Math.max(1, ...all.map((p) => p[1])) * 1.1;
  const t0 = Math.min(...all.map((p) => p[0]));
  const t1 = Math.max(...all.map((p) => p[0]));
  const area = frame(ctx, w, h, yMax, t0, t1, "frames/s");
  series.forEach((s, i) => polyline(ctx, area, s.points, t0, t1, yMax, KIND_COLORS[i % KIND_COLORS.length]));
  return drawn;
}

let last = null;

function draw() {
  if (!last) return;
  const samples = last.samples;
  window.__plots = {
    samples: samples.length,
    drawn: {
      throughput: drawThroughput(samples),
      waits: drawWaits(last.wait_times),
      kinds: drawKinds(samples),
    },
  };
  const span = samples.length ? samples[samples.length - 1].time - samples[0].time : 0;
  note.textContent = `(${samples.length} samples, ${fmtClock(span)})`;
}

async function refresh() {
  try {
    const response = await fetch("/api/metrics/history");
    if (!response.ok) return;
    last = await response.json();
    draw();
  } catch {
    // The feed's status shows a lost server; the next refresh tries again.
  }
}

window.addEventListener("resize", draw);
refresh();
setInterval(refresh, REFRESH_MS);
