// The status page: polls the read-only JSON API and draws what it says. No framework, no build.
"use strict";

const $ = (sel, root = document) => root.querySelector(sel);
const cams = new Map();          // camera id -> {el, frame, roi draft, ...}
let roiInfo = null;              // /api/roi
let bins = [];                   // /api/history bins, oldest first
let lastState = null;

// -- fetching ---------------------------------------------------------------------------------
async function api(path, options) {
  const response = await fetch(path, Object.assign({cache: "no-store"}, options));
  if (!response.ok) throw new Error(`${path}: HTTP ${response.status}`);
  return response.status === 204 ? null : response.json();
}

function connection(ok, text) {
  const badge = $("#connection");
  badge.textContent = text;
  badge.className = "badge " + (ok ? "ok" : "bad");
}

function every(ms, fn) {
  const run = async () => {
    try { await fn(); } catch (err) { connection(false, "no answer: " + err.message); }
    setTimeout(run, ms);
  };
  run();
}

// -- formatting -------------------------------------------------------------------------------
const fmt = (x, digits = 2, unit = "") =>
  x === null || x === undefined || Number.isNaN(x) ? "–" : `${Number(x).toFixed(digits)}${unit}`;
const age = (tNs) => {
  if (!tNs) return "–";
  const s = Math.max(0, Date.now() / 1000 - tNs / 1e9);
  return s < 90 ? `${s.toFixed(0)} s ago` : s < 5400 ? `${(s / 60).toFixed(0)} min ago`
    : `${(s / 3600).toFixed(1)} h ago`;
};
const bytes = (n) => n === null || n === undefined ? "–"
  : n >= 2 ** 30 ? `${(n / 2 ** 30).toFixed(1)} GiB` : `${(n / 2 ** 20).toFixed(1)} MiB`;
const STATE_WORDS = {
  ok: "judging",
  warming_up: "warming up: learning the background",
  unstable: "cannot judge: the camera moves",
  dark: "cannot judge: too dark",
  scene_change: "cannot judge: the scene changed, relearning",
  stale: "cannot judge: no recent frame",
};

// -- the site ---------------------------------------------------------------------------------
async function refreshState() {
  const s = await api("/api/state");
  if (!s) { connection(true, "running, no state yet"); return; }
  lastState = s;
  connection(true, `live · ${new Date(s.t_ns / 1e6).toLocaleTimeString()}`);
  $("#site").textContent = s.site;
  const p = $("#precipitation");
  const kind = s.precipitation_type && s.precipitation_type !== "unknown"
    ? s.precipitation_type.toUpperCase() : "PRECIPITATION (type unknown)";
  if (s.precipitation === true) { p.textContent = kind; p.className = "verdict rain"; }
  else if (s.precipitation === false) { p.textContent = "No precipitation"; p.className = "verdict dry"; }
  else { p.textContent = "Unknown: no source can judge"; p.className = "verdict unknown"; }
  $("#ptype").textContent = s.precipitation_type ?? "–";
  const rate = $("#rate");
  rate.textContent = s.rain_rate_mm_h === null ? "none (hover for why)"
    : `${fmt(s.rain_rate_mm_h, 1, " mm/h")} (${s.rain_rate_source ?? "?"})`;
  rate.title = s.rain_rate_reason ?? "";
  $("#intensity").textContent = s.intensity_class ?? "–";
  $("#wawa").textContent = s.wawa ?? "–";
  $("#metar").textContent = s.metar ?? "–";
  $("#visibility").textContent = s.visibility_m === null ? "–" : `${s.visibility_m} m`;
  $("#camera-r").textContent = fmt(s.camera_R, 1);
  const c = s.calibration || {};
  $("#calibration").textContent = c.model === "power"
    ? `mm/h = ${c.a} · R^${c.b} (${c.source}${c.ready ? "" : ", not ready"}; ${c.n} window(s)` +
      `${c.r2 === null || c.r2 === undefined ? "" : `, R² ${fmt(c.r2)}`})`
    : (c.model ?? "none");
  const dis = $("#disagreement");
  dis.hidden = !s.disagreement;
  dis.textContent = s.disagreement ? `Disagreement: ${s.disagreement}` : "";
  $("#reason").textContent = s.reason ?? "";
}

// -- cameras ----------------------------------------------------------------------------------
function cameraCard(id) {
  if (cams.has(id)) return cams.get(id);
  const el = $("#camera-template").content.firstElementChild.cloneNode(true);
  el.dataset.camera = id;
  $(".cam-id", el).textContent = id;
  $("#cameras").appendChild(el);
  const cam = {id, el, frame: null, draft: [], drawing: false, url: null, loading: false};
  cams.set(id, cam);
  const canvas = $(".roi-canvas", el);
  canvas.addEventListener("click", (ev) => addPoint(cam, ev));
  $(".roi-draw", el).addEventListener("click", () => {
    cam.drawing = !cam.drawing;
    $(".roi-draw", el).classList.toggle("active", cam.drawing);
    canvas.classList.toggle("drawing", cam.drawing);
    $("details.roi", el).open = true;
    drawRoi(cam);
  });
  $(".roi-undo", el).addEventListener("click", () => { cam.draft.pop(); drawRoi(cam); });
  $(".roi-clear", el).addEventListener("click", () => { cam.draft = []; drawRoi(cam); });
  $(".roi-save", el).addEventListener("click", () => saveRoi(cam));
  $("details.roi", el).addEventListener("toggle", () => drawRoi(cam));
  $(".overlay", el).addEventListener("load", () => drawRoi(cam));
  return cam;
}

async function refreshCameras() {
  const list = await api("/api/cameras");
  for (const [id, m] of Object.entries(list)) {
    const cam = cameraCard(id);
    const el = cam.el;
    if (!m) continue;
    const v = $(".cam-verdict", el);
    if (m.state !== "ok") {
      v.textContent = m.state === "warming_up" ? "Warming up" : "Cannot judge";
      v.className = "verdict cam-verdict unknown";
    } else if (m.rain) {
      const t = m.camera_precipitation_type;
      v.textContent = t === "snow" ? "Snow seen" : t === "rain" ? "Rain seen" : "Precipitation seen";
      v.className = "verdict cam-verdict rain";
    } else { v.textContent = "No rain"; v.className = "verdict cam-verdict dry"; }
    $(".cam-state", el).textContent = `${m.state} (${STATE_WORDS[m.state] ?? m.state})`;
    $(".cam-type", el).textContent = m.camera_precipitation_type ?? "–";
    $(".cam-pi", el).textContent = `${fmt(m.pi)} (${fmt(m.pi_smoothed)})`;
    $(".cam-mu", el).textContent = fmt(m.mu_smoothed_deg ?? m.mu_deg, 1, "°");
    $(".cam-sigma", el).textContent = fmt(m.sigma_smoothed_deg ?? m.sigma_deg, 1, "°");
    $(".cam-r", el).textContent = `${fmt(m.R, 0)} / ${fmt(m.R_mean, 0)}`;
    $(".cam-fraction", el).textContent = fmt(m.rain_fraction === null ? null : 100 * m.rain_fraction, 0, " %");
    $(".cam-fps", el).textContent = fmt(m.fps, 1);
  }
}

async function refreshImages() {
  for (const cam of cams.values()) {
    if (cam.loading) continue;
    cam.loading = true;
    try {
      const response = await fetch(`/api/cameras/${encodeURIComponent(cam.id)}/overlay.jpg`,
        {cache: "no-store"});
      if (response.status === 200) {
        const url = URL.createObjectURL(await response.blob());
        const img = $(".overlay", cam.el);
        const old = cam.url;
        img.src = url;
        img.dataset.updated = String(Date.now());
        cam.url = url;
        if (old) setTimeout(() => URL.revokeObjectURL(old), 2000);
      }
      cam.frame = await api(`/api/cameras/${encodeURIComponent(cam.id)}/frame`);
      drawRoi(cam);
    } finally { cam.loading = false; }
  }
}

// -- region of interest ---------------------------------------------------------------------
function framePoint(cam, ev) {
  const canvas = $(".roi-canvas", cam.el);
  const box = canvas.getBoundingClientRect();
  const f = cam.frame;
  if (!f) return null;
  return [Math.round((ev.clientX - box.left) / box.width * f.width * 10) / 10,
          Math.round((ev.clientY - box.top) / box.height * f.height * 10) / 10];
}

function addPoint(cam, ev) {
  if (!cam.drawing) return;
  const p = framePoint(cam, ev);
  if (p) { cam.draft.push(p); drawRoi(cam); }
}

function inside(poly, x, y) {  // ray casting; the polygon is closed implicitly
  let c = false;
  for (let i = 0, j = poly.length - 1; i < poly.length; j = i++) {
    const [xi, yi] = poly[i], [xj, yj] = poly[j];
    if ((yi > y) !== (yj > y) && x < (xj - xi) * (y - yi) / (yj - yi) + xi) c = !c;
  }
  return c;
}

const BLOB_COLOURS = ["#888", "#00dc00", "#eb0000", "#008cff", "#6e2896"];

function drawRoi(cam) {
  const canvas = $(".roi-canvas", cam.el);
  const img = $(".overlay", cam.el);
  const f = cam.frame;
  if (!f || !img.naturalWidth) return;
  canvas.width = img.clientWidth; canvas.height = img.clientHeight;
  const sx = canvas.width / f.width, sy = canvas.height / f.height;
  const g = canvas.getContext("2d");
  g.clearRect(0, 0, canvas.width, canvas.height);
  const open = $("details.roi", cam.el).open;
  const active = roiInfo?.cameras?.[cam.id]?.polygon;
  const path = (poly, close) => {
    g.beginPath();
    poly.forEach(([x, y], i) => (i ? g.lineTo(x * sx, y * sy) : g.moveTo(x * sx, y * sy)));
    if (close) g.closePath();
  };
  if (active && active.length >= 3) {
    g.setLineDash([6, 4]); g.strokeStyle = "#4aa3ff"; g.lineWidth = 2;
    path(active, true); g.stroke(); g.setLineDash([]);
  }
  const draft = cam.draft;
  let kept = 0, total = 0;
  if (open && f.blobs) {
    const region = draft.length >= 3 ? draft : null;
    const {x, y} = f.blobs, cls = f.blobs.class;
    for (let i = 0; i < x.length; i++) {
      const isIn = region ? inside(region, x[i], y[i]) : true;
      total++; if (isIn) kept++;
      g.globalAlpha = isIn ? 1 : 0.25;
      g.fillStyle = BLOB_COLOURS[cls[i]] ?? "#888";
      g.beginPath(); g.arc(x[i] * sx, y[i] * sy, isIn ? 3 : 2, 0, 2 * Math.PI); g.fill();
    }
    g.globalAlpha = 1;
  }
  if (draft.length) {
    g.strokeStyle = "#ffd23f"; g.lineWidth = 2; g.fillStyle = "rgba(255,210,63,0.12)";
    path(draft, draft.length >= 3);
    if (draft.length >= 3) g.fill();
    g.stroke();
    g.fillStyle = "#ffd23f";
    for (const [px, py] of draft) { g.beginPath(); g.arc(px * sx, py * sy, 4, 0, 2 * Math.PI); g.fill(); }
  }
  $(".roi-count", cam.el).textContent = open
    ? `${draft.length} point(s) drawn; blobs of the last frame kept: ${kept} of ${total}` : "";
  $(".roi-count", cam.el).dataset.kept = String(kept);
  $(".roi-count", cam.el).dataset.total = String(total);
}

async function saveRoi(cam) {
  const msg = $(".roi-message", cam.el);
  const snippet = $(".roi-snippet", cam.el);
  if (cam.draft.length < 3) { msg.textContent = "Draw at least 3 points first."; return; }
  const response = await fetch(`/api/cameras/${encodeURIComponent(cam.id)}/roi`, {
    method: "POST", headers: {"Content-Type": "application/json"},
    body: JSON.stringify({polygon: cam.draft}),
  });
  const out = await response.json();
  if (out.error) { msg.textContent = out.error; return; }
  if (out.saved) {
    msg.textContent = `Saved to ${out.path}; it takes effect when the daemon restarts.`;
    snippet.hidden = true;
  } else {
    msg.textContent = `Not written (${out.why_not}). Paste this into the configuration:`;
    snippet.textContent = out.snippet;
    snippet.hidden = false;
  }
  msg.dataset.saved = String(out.saved);
}

// -- instruments and health -----------------------------------------------------------------
async function refreshInstruments() {
  const readings = await api("/api/instruments");
  const used = lastState?.instruments ?? {};
  const ids = new Set([...Object.keys(readings), ...Object.keys(used)]);
  if (!ids.size) return;
  const body = $("#instruments tbody");
  body.replaceChildren();
  for (const id of [...ids].sort()) {
    const r = readings[id] ?? {}, u = used[id] ?? {};
    const tr = document.createElement("tr");
    for (const v of [id, r.driver ?? u.driver ?? "–", u.state ?? r.status ?? "–", age(r.t_ns),
      fmt(r.rain_rate_mm_h, 2, " mm/h"), r.wawa ?? "–",
      r.visibility_m === null || r.visibility_m === undefined ? "–" : `${r.visibility_m} m`,
      u.usable === undefined ? "–" : u.usable ? "yes" : "no"]) {
      const td = document.createElement("td"); td.textContent = v; tr.appendChild(td);
    }
    body.appendChild(tr);
  }
}

async function refreshStatus() {
  const s = await api("/api/status");
  if (!s) return;
  const rec = s.recorder ?? {}, z = s.zenoh ?? {}, clock = s.clock ?? {};
  const facts = [
    ["Uptime", s.uptime_s < 3600 ? `${fmt(s.uptime_s / 60, 1)} min` : `${fmt(s.uptime_s / 3600, 1)} h`],
    ["Version", s.versions?.weatherd ?? "–"],
    ["Clock", clock.synchronized === true ? "synchronised" : clock.synchronized === false ? "NOT synchronised" : "unknown"],
    ["Recorder", rec.enabled ? (rec.file ?? "between files") : "off"],
    ["Written", rec.enabled ? `${bytes(rec.file_bytes)} this file, ${bytes(rec.total_bytes)} in all` : "–"],
    ["Disk free", rec.enabled ? bytes(rec.free_bytes) : "–"],
    ["Dropped records", rec.enabled ? String(rec.dropped ?? 0) : "–"],
    ["Zenoh", z.enabled === false ? "off" : !z.session_open ? `no session${z.last_error ? ": " + z.last_error : ""}`
      : z.connected ? "session open, peers connected" : "session open, no peer yet"],
    ["Published", z.puts !== undefined ? `${z.puts} messages${z.put_errors ? `, ${z.put_errors} errors` : ""}` : "–"],
  ];
  const dl = $("#health");
  dl.replaceChildren();
  for (const [k, v] of facts) {
    const dt = document.createElement("dt"); dt.textContent = k;
    const dd = document.createElement("dd"); dd.textContent = v; dd.dataset.key = k;
    dl.append(dt, dd);
  }
  const body = $("#camera-health tbody");
  body.replaceChildren();
  for (const [id, c] of Object.entries(s.cameras ?? {})) {
    const tr = document.createElement("tr");
    for (const v of [id, c.capture_state, c.detector_state ?? "–", fmt(c.fps, 1),
      fmt(c.processing_ms, 1, " ms"), c.frames_dropped, c.reconnects, c.last_error ?? ""]) {
      const td = document.createElement("td"); td.textContent = v ?? "–"; tr.appendChild(td);
    }
    body.appendChild(tr);
  }
}

// -- the last 24 hours ------------------------------------------------------------------------
const PALETTE = ["#4aa3ff", "#f0a030", "#c678dd", "#56b6c2", "#e06c75", "#98c379"];
const STATE_COLOURS = {ok: "#2a3a48", unstable: "#f0a030", warming_up: "#3070b0",
  dark: "#6a4a90", scene_change: "#d0c040"};

async function refreshHistory() {
  const since = bins.length ? bins[bins.length - 1].t : null;
  const out = await api("/api/history" + (since === null ? "" : `?since=${since}`));
  if (since !== null && bins.length && out.bins.length && out.bins[0].t === since) bins.pop();
  bins = bins.concat(out.bins);
  const horizon = Date.now() / 1000 - 86400;
  while (bins.length && bins[0].t < horizon) bins.shift();
  drawHistory();
}

function seriesKeys(pattern) {
  const keys = new Set();
  for (const b of bins) for (const k of Object.keys(b)) if (pattern.test(k)) keys.add(k);
  return [...keys].sort();
}

function plot(canvas, series, {yMax = null, unit = ""} = {}) {
  const g = canvas.getContext("2d");
  const W = canvas.width, H = canvas.height, L = 46, R = 8, T = 8, B = 18;
  g.clearRect(0, 0, W, H);
  const now = Date.now() / 1000;
  const t0 = Math.min(bins.length ? bins[0].t : now - 600, now - 600), t1 = now;
  let ymax = yMax ?? 0;
  if (yMax === null) for (const s of series) for (const b of bins) {
    const v = b[s.key]; if (v !== undefined && v > ymax) ymax = v;
  }
  ymax = ymax > 0 ? ymax * (yMax === null ? 1.1 : 1) : 1;
  const X = (t) => L + (t - t0) / (t1 - t0) * (W - L - R);
  const Y = (v) => H - B - v / ymax * (H - T - B);
  g.strokeStyle = "#2c3640"; g.fillStyle = "#8c99a6"; g.font = "11px sans-serif";
  for (const f of [0, 0.5, 1]) {
    g.beginPath(); g.moveTo(L, Y(f * ymax)); g.lineTo(W - R, Y(f * ymax)); g.stroke();
    g.fillText(`${(f * ymax).toPrecision(2)}${unit}`, 2, Y(f * ymax) + 4);
  }
  for (let i = 0; i <= 4; i++) {
    const t = t0 + i / 4 * (t1 - t0);
    g.fillText(new Date(t * 1000).toLocaleTimeString([], {hour: "2-digit", minute: "2-digit"}),
      Math.min(Math.max(X(t) - 24, L), W - R - 56), H - 4);
  }
  let points = 0;
  series.forEach((s) => {
    g.strokeStyle = s.colour; g.lineWidth = 1.5; g.beginPath();
    let pen = false, last = null;
    for (const b of bins) {
      const v = b[s.key];
      if (v === undefined || v === null || (last !== null && b.t - last > 30)) pen = false;
      if (v === undefined || v === null) continue;
      if (pen) g.lineTo(X(b.t + 5), Y(Math.min(v, ymax))); else g.moveTo(X(b.t + 5), Y(Math.min(v, ymax)));
      pen = true; last = b.t; points++;
    }
    g.stroke();
  });
  canvas.dataset.points = String(points);
}

function drawHistory() {
  const legend = [];
  const camKeys = seriesKeys(/^cam\.(.+)\.rain_fraction$/);
  const cams = camKeys.map((k) => k.split(".").slice(1, -1).join("."));
  const fr = cams.map((c, i) => ({key: `cam.${c}.rain_fraction`, colour: PALETTE[i % PALETTE.length]}));
  plot($("#plot-fraction"), fr, {yMax: 1});
  plot($("#plot-r"), cams.map((c, i) => ({key: `cam.${c}.R`, colour: PALETTE[i % PALETTE.length]})));
  cams.forEach((c, i) => legend.push([`camera ${c}`, PALETTE[i % PALETTE.length]]));
  const rate = [{key: "rate_mm_h", colour: "#e8edf2"}, {key: "camera_rate_mm_h", colour: "#39d353"}];
  seriesKeys(/^inst\.(.+)\.rate_mm_h$/).forEach((k, i) => {
    rate.push({key: k, colour: PALETTE[(i + 3) % PALETTE.length]});
    legend.push([`gauge ${k.split(".")[1]}`, PALETTE[(i + 3) % PALETTE.length]]);
  });
  plot($("#plot-rate"), rate, {unit: ""});
  legend.push(["site rate", "#e8edf2"], ["camera rate (calibrated)", "#39d353"]);
  drawBands($("#plot-bands"), cams);
  const p = $("#plot-legend");
  p.replaceChildren();
  for (const [name, colour] of legend.concat([["precipitation / rain", "#39d353"],
    ["unstable", STATE_COLOURS.unstable], ["warming up", STATE_COLOURS.warming_up],
    ["dark", STATE_COLOURS.dark]])) {
    const span = document.createElement("span");
    const sw = document.createElement("span");
    sw.className = "swatch"; sw.style.background = colour;  // CSSOM, allowed by the CSP
    span.append(sw, " " + name);
    p.appendChild(span);
  }
}

function drawBands(canvas, camIds) {
  const g = canvas.getContext("2d");
  const W = canvas.width, H = canvas.height, L = 46, R = 8;
  g.clearRect(0, 0, W, H);
  const rows = [["site", (b) => b.precipitation === undefined ? null
    : b.precipitation >= 0.5 ? "#39d353" : "#2a3a48"]];
  for (const c of camIds) rows.push([c, (b) => {
    const st = b[`cam.${c}.state`];
    if (st === undefined) return null;
    if (st === "ok") return (b[`cam.${c}.rain_fraction`] ?? 0) >= 0.5 ? "#39d353" : STATE_COLOURS.ok;
    return STATE_COLOURS[st] ?? "#888";
  }]);
  const now = Date.now() / 1000;
  const t0 = Math.min(bins.length ? bins[0].t : now - 600, now - 600), t1 = now;
  const X = (t) => L + (t - t0) / (t1 - t0) * (W - L - R);
  const h = Math.min(24, (H - 4) / rows.length);
  g.font = "11px sans-serif";
  rows.forEach(([name, colour], r) => {
    g.fillStyle = "#8c99a6"; g.fillText(name.slice(0, 7), 2, r * h + h * 0.7);
    for (const b of bins) {
      const c = colour(b);
      if (!c) continue;
      g.fillStyle = c;
      g.fillRect(X(b.t), r * h + 2, Math.max(1, X(b.t + 10) - X(b.t)), h - 4);
    }
  });
}

// -- start ------------------------------------------------------------------------------------
async function refreshRoiInfo() { roiInfo = await api("/api/roi"); }

window.addEventListener("DOMContentLoaded", () => {
  every(1000, refreshState);
  every(1000, refreshCameras);
  every(1000, refreshImages);
  every(2000, refreshInstruments);
  every(5000, refreshStatus);
  every(10000, refreshHistory);
  every(30000, refreshRoiInfo);
  window.addEventListener("resize", () => { drawHistory(); cams.forEach(drawRoi); });
});
