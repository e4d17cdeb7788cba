// twinray preview: the page. Sends the controls' settings to the server
// (one request at a time, the newest wins), shows the frames its WebSocket
// sends (coarse to fine; frames of an older change are dropped), and the
// comfort display of each change: histogram, rig, violations, command.
// A panorama is shown in a look-around viewer: the frame's equirectangular
// (or fisheye) image reprojected to a perspective view turned by dragging.
"use strict";

const $ = (id) => document.getElementById(id);
const el = {
  frame: $("frame"), overlay: $("overlay"), stage: $("stage"), status: $("status"),
  error: $("error"), scene: $("scene"),
  interaxial: $("interaxial"), interaxialValue: $("interaxial-value"), interaxialAuto: $("interaxial-auto"),
  convergence: $("convergence"), convergenceValue: $("convergence-value"), convergenceMode: $("convergence-mode"),
  budgetNear: $("budget-near"), budgetFar: $("budget-far"), views: $("views"),
  layout: $("layout"), eye: $("eye"), quilt: $("quilt"), samples: $("samples"), fast: $("fast"),
  from: $("from"), at: $("at"), fov: $("fov"), cameraReset: $("camera-reset"),
  histogram: $("histogram"), numbers: $("numbers"), messages: $("messages"),
  command: $("command"), copy: $("copy"), renderFull: $("render-full"),
  fullStatus: $("full-status"), downloads: $("downloads"),
  look: $("look"), lookControls: $("look-controls"), lookMode: $("look-mode"),
  lookFov: $("look-fov"), lookFovValue: $("look-fov-value"), flatHint: $("flat-hint"),
  angularBudget: $("angular-budget"),
};

// What the tests and the benchmark read.
const preview = (window.twinrayPreview = {
  session: null, generation: 0, frames: 0, lastHeader: null, info: null,
  errors: [], changes: 0,
  // Milliseconds from sending a change to its first frame painted (the
  // benchmark reads them).
  latencies: [], sentAt: 0, measured: 0,
  // The look-around viewer's direction (degrees), field of view and draws.
  // `drawn`: the frame count when the image it shows arrived; `shown`:
  // the yaw, pitch and field of view it was drawn with, and whether at full
  // resolution; `ms` and `dragMs`: the time of the newest draw at full
  // and at half resolution.
  look: { yaw: 0, pitch: 0, fov: 75, draws: 0, loaded: 0, drawn: 0, shown: null, ms: 0, dragMs: 0 },
  // Where the histogram marks the budget and the nearest and farthest
  // points (degrees for a panorama).
  histogramMarks: null,
});

let settings = null;       // what the server gets
let info = null;           // its answer to the newest accepted change
let inFlight = false, pending = false;
let interaxialMax = 1;     // the slider's range, scene units
let convergenceRange = [0.1, 100];
let viewImages = [];       // the newest frame's images (wiggle, single eye)
let wiggleTimer = null;
let urls = [];
let maxPages = 0;         // pages the server takes at once
let projection = "pinhole"; // or the panorama the viewer shows
const isPanorama = () => projection !== "pinhole";

function showError(text) {
  el.error.hidden = !text;
  el.error.textContent = text || "";
  if (text) preview.errors.push(text);
}

function setStatus(text) { el.status.textContent = text; }

function fmt(v, digits = 4) {
  if (v === null || v === undefined) return "–";
  if (typeof v !== "number") return String(v);
  if (v !== 0 && (Math.abs(v) >= 1e5 || Math.abs(v) < 1e-3)) return v.toExponential(3);
  return Number(v.toFixed(digits)).toString();
}

function vecText(v) { return v.map((x) => fmt(x, 4)).join(","); }

function parseVec(text) {
  const parts = text.split(",").map((s) => Number(s.trim()));
  return parts.length === 3 && parts.every(Number.isFinite) ? parts : null;
}

// ---------------------------------------------------------------- controls

function budgetText() {
  const near = Number(el.budgetNear.value), far = Number(el.budgetFar.value);
  if (near === -1 && far === 2) return "";
  const sign = (v) => (v >= 0 ? "+" : "") + v;
  return `${sign(near)}%,${sign(far)}%`;
}

function interaxialFromSlider() {
  const t = Number(el.interaxial.value) / 1000;
  return interaxialMax * t * t;
}

function sliderFromInteraxial(v) {
  return Math.round(1000 * Math.sqrt(Math.max(0, Math.min(1, v / interaxialMax))));
}

function convergenceFromSlider() {
  const [lo, hi] = convergenceRange;
  const t = Number(el.convergence.value) / 1000;
  return lo * Math.pow(hi / lo, t);
}

function sliderFromConvergence(v) {
  const [lo, hi] = convergenceRange;
  return Math.round(1000 * Math.log(v / lo) / Math.log(hi / lo));
}

function readControls() {
  settings.interaxial = el.interaxialAuto.checked ? "auto" : String(Number(el.interaxialValue.value));
  const mode = el.convergenceMode.value;
  settings.convergence = mode === "value" ? String(Number(el.convergenceValue.value)) : mode;
  settings.depth_budget = budgetText();
  if (isPanorama()) {
    // Parallel eyes: the convergence is the projection's, the budget angular.
    settings.convergence = "auto";
    settings.depth_budget = "";
    const b = el.angularBudget.value.trim();
    settings.angular_budget = b === "" ? null : Number(b);
  }
  settings.views = Number(el.views.value);
  settings.view = el.layout.value;
  settings.eye = Number(el.eye.value || 0);
  settings.quilt = el.quilt.value.trim();
  settings.samples = el.samples.value === "" ? null : Number(el.samples.value);
  settings.fast = el.fast.checked;
}

function writeControls() {
  el.interaxialAuto.checked = settings.interaxial === "auto";
  if (settings.interaxial !== "auto") el.interaxialValue.value = settings.interaxial;
  const c = settings.convergence;
  el.convergenceMode.value = ["auto", "near", "inf"].includes(c) ? c : "value";
  if (el.convergenceMode.value === "value") el.convergenceValue.value = c;
  el.views.value = settings.views;
  el.layout.value = settings.view;
  el.quilt.value = settings.quilt;
  el.samples.value = settings.samples === null ? "" : String(settings.samples);
  el.fast.checked = settings.fast;
  el.angularBudget.value = settings.angular_budget == null ? "" : settings.angular_budget;
  const m = /^([-+]?[\d.]+)%,([-+]?[\d.]+)%$/.exec(settings.depth_budget || "");
  if (m) { el.budgetNear.value = Number(m[1]); el.budgetFar.value = Number(m[2]); }
  updateEyes();
  layoutVisibility();
}

function updateEyes() {
  const n = Number(el.views.value) || 2;
  const keep = Math.min(Number(el.eye.value || 0), n - 1);
  el.eye.innerHTML = "";
  for (let i = 0; i < n; i++) {
    const o = document.createElement("option");
    o.value = i;
    o.textContent = n === 1 ? "the one eye" : n === 2 ? (i === 0 ? "left" : "right") : `view ${i}`;
    el.eye.appendChild(o);
  }
  el.eye.value = keep;
}

function layoutVisibility() {
  el.eye.hidden = el.layout.value !== "single";
  el.quilt.hidden = el.layout.value !== "quilt";
}

function changed() {
  readControls();
  send();
}

el.interaxial.addEventListener("input", () => {
  el.interaxialAuto.checked = false;
  el.interaxialValue.value = fmt(interaxialFromSlider(), 5);
  changed();
});
el.interaxialValue.addEventListener("change", () => { el.interaxialAuto.checked = false; changed(); });
el.interaxialAuto.addEventListener("change", changed);
el.convergence.addEventListener("input", () => {
  el.convergenceMode.value = "value";
  el.convergenceValue.value = fmt(convergenceFromSlider(), 5);
  changed();
});
el.convergenceValue.addEventListener("change", () => { el.convergenceMode.value = "value"; changed(); });
el.convergenceMode.addEventListener("change", changed);
for (const e of [el.budgetNear, el.budgetFar, el.angularBudget, el.quilt, el.samples, el.fast, el.eye]) {
  e.addEventListener("change", changed);
}
el.views.addEventListener("change", () => { updateEyes(); changed(); });
el.layout.addEventListener("change", () => {
  if (el.layout.value === "quilt" && Number(el.views.value) === 2) el.views.value = 8;
  if (["anaglyph", "sbs", "cross"].includes(el.layout.value)) el.views.value = 2;
  updateEyes();
  layoutVisibility();
  changed();
});

// ---------------------------------------------------------------- camera

function cameraFromInputs() {
  const from = parseVec(el.from.value), at = parseVec(el.at.value), fov = Number(el.fov.value);
  if (!from || !at || !(fov > 0)) { showError("the camera needs from and at as X,Y,Z and a field of view > 0"); return null; }
  const up = settings.camera ? settings.camera.up : (info ? info.camera.up : [0, 1, 0]);
  return { from, at, up, fov };
}

for (const e of [el.from, el.at, el.fov]) {
  e.addEventListener("change", () => {
    const cam = cameraFromInputs();
    if (cam) { settings.camera = cam; send(); }
  });
}
el.cameraReset.addEventListener("click", () => { settings.camera = null; send(); });

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross3 = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => scale(a, 1 / Math.hypot(a[0], a[1], a[2]));

// Rotates v about the unit axis k by angle (Rodrigues).
function rotate(v, k, angle) {
  const c = Math.cos(angle), s = Math.sin(angle);
  return add(add(scale(v, c), scale(cross3(k, v), s)), scale(k, dot(k, v) * (1 - c)));
}

function currentCamera() {
  if (settings.camera) return { ...settings.camera };
  return info ? { ...info.camera } : null;
}

let drag = null;
el.stage.addEventListener("pointerdown", (e) => {
  if (isPanorama()) return; // the viewer turns the view; the panorama stays
  const cam = currentCamera();
  if (!cam) return;
  drag = { x: e.clientX, y: e.clientY, cam };
  el.stage.setPointerCapture(e.pointerId);
});
el.stage.addEventListener("pointermove", (e) => {
  if (!drag) return;
  const { cam } = drag;
  const yaw = -(e.clientX - drag.x) * 0.006, pitch = -(e.clientY - drag.y) * 0.006;
  const up = norm(cam.up);
  let offset = sub(cam.from, cam.at);
  offset = rotate(offset, up, yaw);
  const right = norm(cross3(scale(offset, -1), up));
  const pitched = rotate(offset, right, pitch);
  // Not over the pole: the view direction must not reach the up axis.
  if (Math.abs(dot(norm(pitched), up)) < 0.98) offset = pitched;
  settings.camera = { from: add(cam.at, offset), at: cam.at, up: cam.up, fov: cam.fov };
  send();
});
const endDrag = () => { drag = null; };
el.stage.addEventListener("pointerup", endDrag);
el.stage.addEventListener("pointercancel", endDrag);
el.stage.addEventListener("wheel", (e) => {
  if (isPanorama()) return;
  e.preventDefault();
  const cam = currentCamera();
  if (!cam) return;
  const factor = Math.exp(Math.sign(e.deltaY) * 0.1);
  settings.camera = { ...cam, from: add(cam.at, scale(sub(cam.from, cam.at), factor)) };
  send();
}, { passive: false });

// ---------------------------------------------------------------- server

async function send() {
  if (!preview.session || !settings) return;
  if (inFlight) { pending = true; return; }
  inFlight = true;
  preview.sentAt = performance.now();
  const sent = JSON.stringify(settings);
  try {
    const r = await fetch(`/api/session/${preview.session}/view`, {
      method: "POST", headers: { "Content-Type": "application/json" }, body: sent,
    });
    const body = await r.json();
    if (r.ok) {
      preview.changes += 1;
      preview.generation = body.generation;
      preview.info = info = body;
      showError("");
      showInfo();
    } else {
      showError(body.error || `HTTP ${r.status}`);
    }
  } catch (err) {
    showError(`the server did not answer: ${err}`);
  } finally {
    inFlight = false;
    if (pending) { pending = false; send(); }
  }
}

function connect() {
  const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/api/session`);
  ws.binaryType = "arraybuffer";
  ws.onmessage = (e) => {
    if (typeof e.data === "string") return onText(JSON.parse(e.data));
    onFrame(e.data);
  };
  ws.onclose = () => {
    if (preview.session === null) {
      // Refused before its hello: the only refusal a page of the server's
      // own can meet is the cap on pages open.
      showError(`the server did not take this page: at most ${maxPages} pages may be open at once (close one, then reload this one)`);
    }
    setStatus("disconnected (reload the page)");
    preview.session = null;
  };
}

function onText(m) {
  if (m.type === "hello") {
    preview.session = m.session;
    setStatus("connected");
    send();
  } else if (m.type === "progress" && m.generation === preview.generation) {
    setStatus(`pass ${m.pass + 1}: ${Math.round((100 * m.done) / m.total)}%`);
  } else if (m.type === "error" && m.generation === preview.generation) {
    showError(m.error);
  } else if (m.type === "full-progress") {
    el.fullStatus.textContent = `rendering ${Math.round((100 * m.done) / m.total)}%`;
  }
}

function onFrame(buffer) {
  const view = new DataView(buffer);
  const len = view.getUint32(0, true);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, len)));
  if (header.generation < preview.generation) return; // an older change's frame
  let at = 4 + len;
  for (const u of urls) URL.revokeObjectURL(u);
  urls = header.sizes.map((size) => {
    const blob = new Blob([new Uint8Array(buffer, at, size)], { type: "image/png" });
    at += size;
    return URL.createObjectURL(blob);
  });
  viewImages = urls;
  if (header.generation > preview.measured) {
    // The first frame of a change: timed when it is painted.
    preview.measured = header.generation;
    const sentAt = preview.sentAt;
    el.frame.addEventListener("load", () => requestAnimationFrame(() => {
      preview.latencies.push(performance.now() - sentAt);
    }), { once: true });
  }
  preview.frames += 1;
  preview.lastHeader = header;
  const what = header.sampling === "final" ? "anti-aliased" : `1/${header.divisor}`;
  setStatus(`${what} ${header.width}×${header.height} · pass ${header.pass + 1}/${header.passes} · ${header.ms.toFixed(0)} ms after the change`);
  el.frame.classList.toggle("final", header.divisor === 1);
  showFrame();
}

function showFrame() {
  if (wiggleTimer) { clearInterval(wiggleTimer); wiggleTimer = null; }
  if (!viewImages.length) return;
  const mode = info ? info.view : settings.view;
  if (mode === "single") {
    el.frame.src = viewImages[Math.min(settings.eye, viewImages.length - 1)];
  } else if (mode === "wiggle" && viewImages.length > 1) {
    // Back and forth through the views (left, right, left, … for a pair).
    const order = [...viewImages.keys(), ...[...viewImages.keys()].reverse().slice(1, -1)];
    let i = 0;
    el.frame.src = viewImages[0];
    wiggleTimer = setInterval(() => { i = (i + 1) % order.length; el.frame.src = viewImages[order[i]]; }, 140);
  } else {
    el.frame.src = viewImages[0];
  }
}

el.frame.addEventListener("load", () => { drawOverlay(); if (isPanorama()) lookSource(); });
window.addEventListener("resize", drawOverlay);

// ---------------------------------------------------------------- comfort

function drawOverlay() {
  const c = el.overlay;
  const w = el.frame.clientWidth, h = el.frame.clientHeight;
  c.width = w; c.height = h;
  c.style.width = w + "px"; c.style.height = h + "px";
  const g = c.getContext("2d");
  g.clearRect(0, 0, w, h);
  if (!info || !info.report) return;
  const single = info.view === "single" || info.view === "wiggle";
  const sx = w / (single ? info.width : info.frame.width), sy = h / (single ? info.height : info.frame.height);
  g.fillStyle = "rgba(255, 40, 40, 0.45)";
  g.strokeStyle = "rgba(255, 80, 80, 0.95)";
  for (const v of info.report.window_violations) {
    if (info.view === "single" && v.view !== settings.eye) continue;
    const tile = info.frame.tiles[v.view] || [0, 0, info.width, info.height];
    const x0 = single ? 0 : tile[0], y0 = single ? 0 : tile[1];
    const width = Math.max(v.mask_px, 2);
    const x = v.edge === "left" ? x0 : x0 + info.width - width;
    const y = y0 + v.first_row, rows = v.last_row - v.first_row + 1;
    g.fillRect(x * sx, y * sy, Math.max(width * sx, 3), rows * sy);
    g.strokeRect(x * sx, y * sy, Math.max(width * sx, 3), rows * sy);
  }
}

function drawHistogram() {
  const c = el.histogram;
  const dpr = window.devicePixelRatio || 1;
  const W = c.clientWidth || 360, H = c.clientHeight || 140;
  c.width = W * dpr; c.height = H * dpr;
  const g = c.getContext("2d");
  g.scale(dpr, dpr);
  g.clearRect(0, 0, W, H);
  if (info && info.panorama) { drawAngularHistogram(g, W, H, info.panorama); return; }
  const h = info && info.histogram, r = info && info.report;
  if (!h || !r) { g.fillStyle = "#8c9196"; g.fillText("no depth pass (one view)", 10, 20); return; }
  const pad = { l: 8, r: 8, t: 8, b: 30 };
  const lo = h.start_px, hi = h.start_px + h.bin_px * h.counts.length;
  const X = (px) => pad.l + ((px - lo) / (hi - lo)) * (W - pad.l - pad.r);
  const peak = Math.max(1, ...h.counts);
  const plotH = H - pad.t - pad.b;
  // The budget: the band allowed, its edges.
  g.fillStyle = "rgba(123, 216, 143, 0.12)";
  g.fillRect(X(r.budget_px.near), pad.t, X(r.budget_px.far) - X(r.budget_px.near), plotH);
  h.counts.forEach((n, i) => {
    if (!n) return;
    const a = lo + i * h.bin_px, b = a + h.bin_px;
    const outside = b <= r.budget_px.near || a >= r.budget_px.far;
    g.fillStyle = outside ? "#ff6b6b" : "#6cb6ff";
    const bh = Math.max(1, (Math.sqrt(n) / Math.sqrt(peak)) * plotH);
    g.fillRect(X(a), pad.t + plotH - bh, Math.max(1, X(b) - X(a) - 1), bh);
  });
  preview.histogramMarks = { near: r.budget_px.near, far: r.budget_px.far };
  g.strokeStyle = "#7bd88f"; g.lineWidth = 1.5;
  for (const px of [r.budget_px.near, r.budget_px.far]) {
    g.beginPath(); g.moveTo(X(px), pad.t); g.lineTo(X(px), pad.t + plotH); g.stroke();
  }
  g.strokeStyle = "#d8dadc"; g.setLineDash([3, 3]);
  g.beginPath(); g.moveTo(X(0), pad.t); g.lineTo(X(0), pad.t + plotH); g.stroke();
  g.setLineDash([]);
  g.fillStyle = "#8c9196"; g.font = "11px monospace"; g.textAlign = "center";
  const ticks = niceTicks(lo, hi, 6);
  for (const t of ticks) {
    g.fillText(`${fmt(t, 1)}px`, X(t), H - 17);
    g.fillText(`${fmt((100 * t) / h.width, 2)}%`, X(t), H - 4);
  }
  g.textAlign = "left";
  g.fillText("in front", pad.l, pad.t + 10);
  g.textAlign = "right";
  g.fillText("behind the screen", W - pad.r, pad.t + 10);
}

function niceTicks(lo, hi, n) {
  const span = hi - lo;
  if (!(span > 0)) return [lo];
  const step0 = span / n, mag = Math.pow(10, Math.floor(Math.log10(step0)));
  const step = [1, 2, 5, 10].map((m) => m * mag).find((s) => s >= step0) || step0;
  const out = [];
  for (let t = Math.ceil(lo / step) * step; t <= hi + 1e-9; t += step) out.push(Math.abs(t) < 1e-9 ? 0 : t);
  return out;
}

function row(name, value, cls) {
  const tr = document.createElement("tr");
  const a = document.createElement("td"), b = document.createElement("td");
  a.textContent = name; b.textContent = value;
  if (cls) b.className = cls;
  tr.append(a, b);
  el.numbers.appendChild(tr);
}

function showInfo() {
  const rig = info.rig, r = info.report;
  // The sliders follow the rig the server chose (auto) or was given.
  if (el.interaxialAuto.checked || interaxialMax <= rig.interaxial) {
    interaxialMax = Math.max(4 * rig.interaxial, 1e-6, interaxialMax);
  }
  if (rig.nearest) {
    const far = Math.min(rig.farthest || rig.nearest * 100, rig.nearest * 200);
    convergenceRange = [rig.nearest * 0.5, Math.max(far * 2, rig.nearest * 4)];
  }
  if (document.activeElement !== el.interaxial) el.interaxial.value = sliderFromInteraxial(rig.interaxial);
  if (document.activeElement !== el.interaxialValue) el.interaxialValue.value = fmt(rig.interaxial, 5);
  const conv = rig.effective_convergence || rig.convergence;
  if (conv && document.activeElement !== el.convergence) el.convergence.value = sliderFromConvergence(conv);
  if (conv && document.activeElement !== el.convergenceValue) el.convergenceValue.value = fmt(conv, 5);
  const cam = info.camera;
  el.from.value = vecText(cam.from);
  el.at.value = vecText(cam.at);
  el.fov.value = fmt(cam.fov, 3);
  el.command.value = info.command;

  el.numbers.innerHTML = "";
  if (info.projection !== "pinhole") { showPanoramaNumbers(); return; }
  row("preview", `${info.width}×${info.height} per view, ${info.views} views`);
  row("interaxial", `${fmt(rig.interaxial, 6)} scene units`);
  row("convergence", `asked ${fmt(rig.convergence)}, effective ${rig.effective_convergence ? fmt(rig.effective_convergence) : "∞ (parallel)"}`);
  row("image shifts", rig.shifts.map((s) => `${s > 0 ? "+" : ""}${s}`).join(" ") + " px");
  row("focal length", `${fmt(rig.focal_px, 1)} px`);
  if (r && r.adjacent_px) {
    const p = r.adjacent_px, q = r.adjacent_percent;
    row("disparity", `${fmt(p.near, 2)} to ${fmt(p.far, 2)} px (${fmt(q.near, 2)}% to ${fmt(q.far, 2)}%)`);
    row("budget", `${fmt(r.budget_px.near, 2)} to ${fmt(r.budget_px.far, 2)} px: ${r.within_budget ? "within" : "EXCEEDED"}`,
        r.within_budget ? "within" : "exceeded");
    if (r.far_on_screen_mm !== undefined) {
      row("far on screen", `${fmt(r.far_on_screen_mm, 1)} mm on a ${r.screen_width_m} m screen${r.diverges ? " (diverges)" : ""}`,
          r.diverges ? "exceeded" : "");
    }
    row("depths", `${fmt(r.depth.nearest)} to ${fmt(r.depth.farthest)}`);
    row("window", r.window_violations.length
      ? r.window_violations.map((v) => `${v.edge} edge of view ${v.view}, rows ${v.first_row}–${v.last_row}, ${fmt(v.disparity_px, 1)} px`).join("; ")
      : "no violations", r.window_violations.length ? "exceeded" : "within");
  } else if (r) {
    row("disparity", "nothing visible");
  }
  if (rig.reason) row("rig chosen", rig.reason);
  showMessages();
  drawHistogram();
  drawOverlay();
}

function showMessages() {
  el.messages.innerHTML = "";
  for (const m of info.messages) {
    const li = document.createElement("li");
    li.className = m.level; li.textContent = m.text;
    el.messages.appendChild(li);
  }
}

// ---------------------------------------------------------------- panoramas

// The controls a panorama takes: the IPD (the interaxial slider) and the
// angular budget; no convergence, flat depth budget, view count, --fast or
// field of view; anaglyph or one eye, shown in the look-around viewer.
function showProjection() {
  const pano = isPanorama();
  $("convergence-row").hidden = pano;
  $("budget-row").hidden = pano;
  $("views-row").hidden = pano;
  $("angular-row").hidden = !pano || settings.views < 2;
  // One eye of a panorama has no rig at all.
  $("rig").hidden = pano && settings.views < 2;
  $("fast-label").hidden = pano;
  $("fov-label").hidden = pano;
  $("interaxial-label").textContent = pano ? "IPD" : "interaxial";
  for (const o of el.layout.options) {
    o.hidden = pano && !(o.value === "single" || (o.value === "anaglyph" && settings.views === 2));
  }
  el.lookControls.hidden = !pano;
  el.flatHint.hidden = pano;
  showLookMode();
}

function showLookMode() {
  const looking = isPanorama() && el.lookMode.value === "look";
  el.look.hidden = !looking;
  el.frame.hidden = looking;
  el.overlay.hidden = looking;
  if (looking) requestLook();
}

el.lookMode.addEventListener("change", showLookMode);

function angle(a) {
  if (!a) return "–";
  return `${fmt(a.deg, 3)}° ${a.distance === null ? "(the background)" : `at distance ${fmt(a.distance)}`}`;
}

function showPanoramaNumbers() {
  const p = info.panorama;
  row("preview", `${info.width}×${info.height} ${info.projection}, ${info.views === 1 ? "one eye" : "2 eyes"}`);
  if (p) {
    row("IPD", `${fmt(p.ipd, 6)} scene units${p.ipd_mm === null ? "" : ` = ${fmt(p.ipd_mm, 1)} mm`} (${{
      budget: "the largest within the budget", human: "the eyes' 64 mm", given: "given",
      "at-target": "nothing visible: the budget at the target's distance" }[p.chosen_by]})`);
    row("nearest", angle(p.near), p.within_budget ? "within" : "exceeded");
    row("farthest", angle(p.far));
    row("budget", `${fmt(p.budget_deg, 3)}° at the nearest point: ${p.within_budget ? "within" : "EXCEEDED"}`,
        p.within_budget ? "within" : "exceeded");
    row("scene unit", p.units === null ? "unknown: --units m (cm, mm, in, ft) keeps the IPD to the eyes' 64 mm" : p.units);
  }
  showMessages();
  drawHistogram();
  drawOverlay();
}

// The depth pass's samples by angular disparity: 0° (infinity) on the
// left, the nearest points on the right; the budget as a band and a line,
// the nearest and farthest points marked.
function drawAngularHistogram(g, W, H, p) {
  const h = p.histogram;
  const pad = { l: 8, r: 8, t: 8, b: 30 };
  const span = h.bin_deg * h.counts.length;
  const X = (deg) => pad.l + (deg / span) * (W - pad.l - pad.r);
  const plotH = H - pad.t - pad.b;
  const peak = Math.max(1, ...h.counts);
  g.fillStyle = "rgba(123, 216, 143, 0.12)";
  g.fillRect(X(0), pad.t, X(Math.min(p.budget_deg, span)) - X(0), plotH);
  h.counts.forEach((n, i) => {
    if (!n) return;
    const a = i * h.bin_deg, b = a + h.bin_deg;
    // Bars past the budget's line in red.
    g.fillStyle = a >= p.budget_deg ? "#ff6b6b" : "#6cb6ff";
    const bh = Math.max(1, (Math.sqrt(n) / Math.sqrt(peak)) * plotH);
    g.fillRect(X(a), pad.t + plotH - bh, Math.max(1, X(b) - X(a) - 1), bh);
  });
  g.strokeStyle = "#7bd88f"; g.lineWidth = 1.5;
  g.beginPath(); g.moveTo(X(p.budget_deg), pad.t); g.lineTo(X(p.budget_deg), pad.t + plotH); g.stroke();
  g.font = "11px monospace";
  g.fillStyle = "#7bd88f";
  g.textAlign = X(p.budget_deg) > W / 2 ? "right" : "left";
  g.fillText(`budget ${fmt(p.budget_deg, 2)}°`, X(p.budget_deg) + (X(p.budget_deg) > W / 2 ? -4 : 4), pad.t + 38);
  const marks = { budget: p.budget_deg };
  for (const [name, a, colour] of [["nearest", p.near, "#ffcf6b"], ["farthest", p.far, "#d8dadc"]]) {
    if (!a) continue;
    marks[name] = a.deg;
    g.strokeStyle = colour; g.setLineDash([3, 3]);
    g.beginPath(); g.moveTo(X(a.deg), pad.t); g.lineTo(X(a.deg), pad.t + plotH); g.stroke();
    g.setLineDash([]);
    g.fillStyle = colour;
    g.textAlign = X(a.deg) > W / 2 ? "right" : "left";
    g.fillText(`${name} ${fmt(a.deg, 2)}°`, X(a.deg) + (X(a.deg) > W / 2 ? -4 : 4), pad.t + (name === "nearest" ? 10 : 24));
  }
  preview.histogramMarks = marks;
  g.fillStyle = "#8c9196"; g.textAlign = "center";
  for (const t of niceTicks(0, span, 6)) g.fillText(`${fmt(t, 2)}°`, X(t), H - 17);
  g.textAlign = "left";
  g.fillText("← far (0°: infinity), angular disparity", pad.l, H - 4);
  g.textAlign = "right";
  g.fillText("near →", W - pad.r, H - 4);
}

// The look-around viewer: each canvas pixel's ray of a perspective camera
// turned by yaw and pitch, looked up in the frame's image by the
// projection's formula (rig/projection.rs), bilinearly.
const look = preview.look;
let lookImage = null;  // { width, height, data } of the frame shown
const lookScratch = document.createElement("canvas");
let lookQueued = false;

function lookSource() {
  const img = el.frame;
  if (!img.naturalWidth) return;
  const c = document.createElement("canvas");
  c.width = img.naturalWidth; c.height = img.naturalHeight;
  const g = c.getContext("2d", { willReadFrequently: true });
  g.drawImage(img, 0, 0);
  lookImage = { width: c.width, height: c.height, data: g.getImageData(0, 0, c.width, c.height).data };
  look.loaded = preview.frames;
  requestLook();
}

function requestLook() {
  if (lookQueued || el.look.hidden) return;
  lookQueued = true;
  requestAnimationFrame(() => { lookQueued = false; drawLook(); });
}

function drawLook() {
  const start = performance.now();
  const canvas = el.look;
  const dpr = Math.min(window.devicePixelRatio || 1, 2);
  const W = Math.max(16, Math.min(1280, Math.round(canvas.clientWidth * dpr)));
  const H = Math.max(9, Math.round((W * 9) / 16));
  if (canvas.width !== W || canvas.height !== H) { canvas.width = W; canvas.height = H; }
  const g = canvas.getContext("2d");
  if (!lookImage) { g.fillStyle = "#000"; g.fillRect(0, 0, W, H); return; }
  // Half the resolution while a drag turns the view, the whole when it ends.
  const full = !lookDrag;
  const Wd = full ? W : Math.ceil(W / 2), Hd = full ? H : Math.ceil(H / 2);
  const { width: w, height: h, data: src } = lookImage;
  const out = g.createImageData(Wd, Hd);
  const d = out.data;
  lookDraw(d, Wd, Hd, w, h, src);
  if (full) {
    g.putImageData(out, 0, 0);
  } else {
    lookScratch.width = Wd; lookScratch.height = Hd;
    lookScratch.getContext("2d").putImageData(out, 0, 0);
    g.drawImage(lookScratch, 0, 0, W, H);
  }
  look.draws += 1;
  look.drawn = look.loaded;
  look.shown = [look.yaw, look.pitch, look.fov, full];
  look[full ? "ms" : "dragMs"] = performance.now() - start;
}

// The view into `d` (RGBA, W by H) from the source image `src` (w by h).
function lookDraw(d, W, H, w, h, src) {
  const f = H / 2 / Math.tan(((look.fov * Math.PI) / 180) / 2);
  const yaw = (look.yaw * Math.PI) / 180, pitch = (look.pitch * Math.PI) / 180;
  const cy = Math.cos(yaw), sy = Math.sin(yaw), cp = Math.cos(pitch), sp = Math.sin(pitch);
  // Where a direction (right x, up y, forward z) lands in the source, in
  // pixels with centres at integers: the projection's formula.
  const fisheye = projection === "vr180-fisheye", half = projection === "vr180";
  const wrap = !fisheye && !half;
  const perLon = w / (half ? Math.PI : 2 * Math.PI), perLat = h / Math.PI;
  for (let j = 0; j < H; j++) {
    const py = (H / 2 - j - 0.5) / f;
    let at = j * W * 4;
    for (let i = 0; i < W; i++, at += 4) {
      d[at + 3] = 255;
      const px = (i + 0.5 - W / 2) / f;
      const n = 1 / Math.sqrt(px * px + py * py + 1);
      // Pitch about the right axis, then yaw about the up axis.
      const y = (py * cp + sp) * n, z1 = (-py * sp + cp) * n, x1 = px * n;
      const x = x1 * cy + z1 * sy, z = -x1 * sy + z1 * cy;
      let u, v;
      if (fisheye) {
        if (z < 0) continue;
        const rho = Math.acos(z > 1 ? 1 : z) / (Math.PI / 2);
        const r = Math.hypot(x, y) || 1;
        u = ((rho * x) / r + 1) * 0.5 * w - 0.5;
        v = ((1 - (rho * y) / r) * 0.5) * h - 0.5;
      } else {
        const lon = Math.atan2(x, z);
        if (half && Math.abs(lon) > Math.PI / 2) continue;
        u = lon * perLon + w / 2 - 0.5;
        v = h / 2 - Math.asin(y > 1 ? 1 : y < -1 ? -1 : y) * perLat - 0.5;
      }
      // Bilinear, across the 360° seam where there is one.
      let i0 = Math.floor(u), j0 = Math.floor(v);
      const fx = u - i0, fy = v - j0;
      let i1 = i0 + 1, j1 = j0 + 1;
      if (wrap) {
        if (i0 < 0) i0 += w; else if (i0 >= w) i0 -= w;
        if (i1 >= w) i1 -= w; else if (i1 < 0) i1 += w;
      } else {
        i0 = i0 < 0 ? 0 : i0 >= w ? w - 1 : i0;
        i1 = i1 < 0 ? 0 : i1 >= w ? w - 1 : i1;
      }
      j0 = j0 < 0 ? 0 : j0 >= h ? h - 1 : j0;
      j1 = j1 < 0 ? 0 : j1 >= h ? h - 1 : j1;
      const a = (j0 * w + i0) * 4, b = (j0 * w + i1) * 4, c = (j1 * w + i0) * 4, e = (j1 * w + i1) * 4;
      const w00 = (1 - fx) * (1 - fy), w10 = fx * (1 - fy), w01 = (1 - fx) * fy, w11 = fx * fy;
      d[at] = src[a] * w00 + src[b] * w10 + src[c] * w01 + src[e] * w11;
      d[at + 1] = src[a + 1] * w00 + src[b + 1] * w10 + src[c + 1] * w01 + src[e + 1] * w11;
      d[at + 2] = src[a + 2] * w00 + src[b + 2] * w10 + src[c + 2] * w01 + src[e + 2] * w11;
    }
  }
}

function setLookFov(fov) {
  look.fov = Math.max(20, Math.min(120, fov));
  el.lookFov.value = Math.round(look.fov);
  el.lookFovValue.textContent = `${Math.round(look.fov)}°`;
  requestLook();
}

el.lookFov.addEventListener("input", () => setLookFov(Number(el.lookFov.value)));

// Dragging carries the scene with the pointer (mouse, pen or a finger).
let lookDrag = null;
el.look.addEventListener("pointerdown", (e) => {
  lookDrag = { x: e.clientX, y: e.clientY, yaw: look.yaw, pitch: look.pitch, id: e.pointerId };
  el.look.setPointerCapture(e.pointerId);
  e.preventDefault();
});
el.look.addEventListener("pointermove", (e) => {
  if (!lookDrag || e.pointerId !== lookDrag.id) return;
  const perPixel = look.fov / Math.max(1, el.look.clientHeight);
  look.yaw = lookDrag.yaw - (e.clientX - lookDrag.x) * perPixel;
  look.yaw = ((look.yaw + 540) % 360) - 180;
  look.pitch = Math.max(-89, Math.min(89, lookDrag.pitch + (e.clientY - lookDrag.y) * perPixel));
  requestLook();
});
for (const end of ["pointerup", "pointercancel"]) {
  el.look.addEventListener(end, () => { lookDrag = null; requestLook(); });
}
el.look.addEventListener("wheel", (e) => {
  e.preventDefault();
  setLookFov(look.fov * Math.exp(Math.sign(e.deltaY) * 0.1));
}, { passive: false });
window.addEventListener("resize", requestLook);

// ---------------------------------------------------------------- command, full render

el.copy.addEventListener("click", async () => {
  try {
    await navigator.clipboard.writeText(el.command.value);
  } catch (_) {
    el.command.select();
    document.execCommand("copy");
  }
  el.copy.textContent = "Copied";
  setTimeout(() => { el.copy.textContent = "Copy"; }, 1200);
});

el.renderFull.addEventListener("click", async () => {
  if (!preview.session) return;
  el.renderFull.disabled = true;
  el.fullStatus.textContent = "rendering…";
  el.downloads.innerHTML = "";
  try {
    const r = await fetch(`/api/session/${preview.session}/render`, {
      method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(settings),
    });
    const body = await r.json();
    if (!r.ok) throw new Error(body.error || `HTTP ${r.status}`);
    el.fullStatus.textContent = `done in ${body.seconds.toFixed(1)} s`;
    for (const f of body.files) {
      const li = document.createElement("li"), a = document.createElement("a");
      a.href = f.url; a.download = f.name; a.textContent = `${f.name} (${Math.round(f.bytes / 1024)} KiB)`;
      li.appendChild(a); el.downloads.appendChild(li);
    }
  } catch (err) {
    el.fullStatus.textContent = "";
    showError(String(err.message || err));
  } finally {
    el.renderFull.disabled = false;
  }
});

// ---------------------------------------------------------------- start

$("reload").addEventListener("click", async () => {
  const r = await fetch("/api/reload", { method: "POST" });
  const state = await r.json();
  if (state.error) showError(state.error);
  else location.reload();
});

async function start() {
  const r = await fetch("/api/state");
  const state = await r.json();
  el.scene.textContent = state.scene;
  maxPages = state.max_pages;
  settings = state.settings;
  projection = state.projection || "pinhole";
  showProjection();
  writeControls();
  if (state.error) {
    showError(state.error);
    setStatus("the scene could not be read");
    $("reload").hidden = false;
    return;
  }
  if (state.preview_size) {
    const [w, h] = state.preview_size;
    el.frame.style.aspectRatio = `auto ${w} / ${h}`;
  }
  connect();
}

start();
