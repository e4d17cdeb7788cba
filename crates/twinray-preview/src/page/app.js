// twinray preview: the page. Sends the controls' settings to the server
// (one request at a time, the newest wins), shows the frames its WebSocket
// sends (coarse to fine; frames of an older change are dropped), and the
// comfort display of each change: histogram, rig, violations, command.
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
};

// What the tests and the benchmark read.
const preview = (window.twinrayPreview = {
  session: null, generation: 0, frames: 0, lastHeader: null, info: null,
  errors: [], changes: 0,
  // Milliseconds from sending a change to its first frame painted (the
  // benchmark reads them).
  latencies: [], sentAt: 0, measured: 0,
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
    o.textContent = n === 2 ? (i === 0 ? "left" : "right") : `view ${i}`;
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
for (const e of [el.budgetNear, el.budgetFar, el.quilt, el.samples, el.fast, el.eye]) {
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

el.frame.addEventListener("load", drawOverlay);
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
  el.messages.innerHTML = "";
  for (const m of info.messages) {
    const li = document.createElement("li");
    li.className = m.level; li.textContent = m.text;
    el.messages.appendChild(li);
  }
  drawHistogram();
  drawOverlay();
}

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
