// refrakt serve's page: shows the frames the server sends and sends the user's edits.
// Protocol: src/serve/protocol.rs. The server keeps the one truth (src/serve/state.rs): every
// edit goes to it and comes back to every page as a `state` message, so pages in several
// windows, or a reloaded page, show what the frame shows. Edits are sent at most once per
// animation frame (the server keeps only the newest state anyway).
"use strict";

const $ = (id) => document.getElementById(id);
const canvas = $("frame");
const ctx2d = canvas.getContext("2d");
// The frame as received, without the lights' dots drawn over it ("save still" saves this).
const film = document.createElement("canvas");
const filmCtx = film.getContext("2d");
const token = new URLSearchParams(location.search).get("token");
const state = {
  me: null, refine: 0, scene: null, camera: null, lights: {}, params: {}, selected: null, time: 0, playing: false,
  frames: 0, last: null, arrivals: [], probe: null, probing: false, nextId: 1, flushed: 0, outbox: new Map(),
  server: null, activity: null, busySeen: [],
};
window.refrakt = state; // for the browser test and the curious

// ---- connection -------------------------------------------------------------------------
let socket;
function connect() {
  // wss:// where the page came over https:// (behind a TLS proxy), ws:// otherwise.
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  socket = new WebSocket(`${scheme}://${location.host}/ws${token ? `?token=${encodeURIComponent(token)}` : ""}`);
  socket.binaryType = "arraybuffer";
  socket.onopen = () => { $("stats").textContent = "connected, waiting for the first frame…"; flush(); };
  socket.onclose = () => { $("stats").textContent = "disconnected; retrying…"; setTimeout(connect, 1000); };
  socket.onmessage = (m) => (typeof m.data === "string" ? onEvent(JSON.parse(m.data)) : onFrame(m.data));
}

// Queues an edit by kind (and light name): a newer one of the same kind replaces it.
function send(key, message) {
  state.outbox.set(key, { ...message, id: state.nextId++ });
  requestAnimationFrame(flush);
}
function flush() {
  if (!socket || socket.readyState !== WebSocket.OPEN) return;
  for (const m of state.outbox.values()) {
    socket.send(JSON.stringify(m));
    state.flushed = Math.max(state.flushed, m.id);
  }
  state.outbox.clear();
}
// A request that is not an edit (no id, not queued).
function ask(message) {
  if (socket?.readyState === WebSocket.OPEN) socket.send(JSON.stringify(message));
}

function onEvent(e) {
  if (e.type === "hello") ({ connection: state.me, refine: state.refine } = e);
  else if (e.type === "scene") onScene(e);
  else if (e.type === "state") onState(e);
  else if (e.type === "activity") { state.activity = e; showActivity(); }
  else if (e.type === "lua") showLua(e.lua);
  else if (e.type === "error") showError(e.message);
  else if (e.type === "ok") showError(null);
  else if (e.type === "warning") console.warn(e.message);
}

function showError(message) {
  $("error").hidden = !message;
  $("error").textContent = message ? `${message}\n(the last good frame stays; save a fix to render again)` : "";
}

// The server's state: what this page shows, unless this page has sent newer edits that the
// state does not hold yet (their own echo follows).
function onState(e) {
  state.server = e;
  $("undo").disabled = !e.can_undo;
  $("redo").disabled = !e.can_redo;
  if (e.by === state.me && e.id !== 0 && (e.id < state.flushed || state.outbox.size)) return;
  state.camera = e.camera ? { ...e.camera } : state.scene && { ...state.scene.camera };
  state.lights = structuredClone(e.lights);
  state.params = { ...e.params };
  state.time = e.time;
  $("time").value = e.time;
  $("time-value").textContent = e.time.toFixed(2);
  $("layer").value = e.display.layer;
  $("exposure").value = e.display.exposure;
  $("exposure-value").textContent = e.display.exposure;
  $("tonemap").value = e.display.tonemap;
  for (const input of document.querySelectorAll("[data-param]")) {
    const v = state.params[input.dataset.param];
    if (v !== undefined) { input.value = v; input.nextElementSibling.textContent = v; }
  }
  showCamera();
  showLight();
  redraw();
}

async function onFrame(buffer) {
  const view = new DataView(buffer);
  const length = view.getUint32(0, true);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, length)));
  const payload = new Uint8Array(buffer, 4 + length);
  if (header.kind === "hdr") return showProbe(header, new Float32Array(payload.slice().buffer));
  // JPEG strips of rows, one after another (encoded on several cores): decode all, then draw.
  let offset = 0;
  const strips = header.strips.map(([y, rows, bytes]) => {
    const part = payload.subarray(offset, offset + bytes);
    offset += bytes;
    return createImageBitmap(new Blob([part], { type: "image/jpeg" })).then((bitmap) => ({ y, bitmap }));
  });
  const decoded = await Promise.all(strips);
  for (const c of [canvas, film]) {
    if (c.width !== header.width || c.height !== header.height) {
      c.width = header.width;
      c.height = header.height;
    }
  }
  for (const { y, bitmap } of decoded) {
    filmCtx.drawImage(bitmap, 0, y);
    bitmap.close();
  }
  redraw();
  state.frames += 1;
  state.last = header;
  state.arrivals.push(performance.now());
  const refine = state.refine > header.samples ? ` (a still view refines to ${state.refine})` : "";
  $("samples").textContent = `${header.samples} samples per pixel${refine}`;
  showStats();
}

function redraw() {
  if (film.width) ctx2d.drawImage(film, 0, 0);
  drawLights();
}

// Frames per second over the last second, kept current between frames (it falls to 0 when
// none arrive), with the samples the shown frame averages.
function showStats() {
  const h = state.last;
  if (!h) return;
  const now = performance.now();
  while (state.arrivals.length && state.arrivals[0] < now - 1000) state.arrivals.shift();
  const t = h.times;
  const gpu = t.gpu.map(([stage, ms]) => `${stage} ${ms.toFixed(2)}`).join(", ");
  const reused = [h.reused.volume && "volume", h.reused.photons && "photons"].filter(Boolean).join(" + ") || "nothing";
  const delivered = Math.max(0, Date.now() - h.ready_us / 1000);
  $("stats").textContent =
    `${state.arrivals.length} fps · frame ${h.frame} ${h.width}×${h.height} · ${h.samples} samples · reused ${reused}\n` +
    `render ${t.render_ms.toFixed(1)} ms · readback ${t.readback_ms.toFixed(1)} · encode ${t.encode_ms.toFixed(1)} · ` +
    `scene ${t.scene_ms.toFixed(1)} · delivery ${delivered.toFixed(1)} ms\nGPU ms: ${gpu || "(no timestamps on this adapter)"}`;
}
setInterval(showStats, 250);

const STAGES = { volume: "building the volume", photons: "tracing photons", view: "tracing camera rays" };
// What the renderer is doing: the part of the frame the GPU is on, how long it has taken and
// how long the last such frame took; or how far a still view has refined.
function showActivity() {
  const a = state.activity;
  const busy = $("busy");
  if (!a) return;
  busy.hidden = !a.busy;
  if (a.busy) {
    const doing = a.refining ? `refining to ${a.samples} of ${a.target} samples` : "rendering";
    const eta = a.eta_ms ? ` of ~${(a.eta_ms / 1000).toFixed(1)} s` : "";
    busy.textContent = `${doing}: ${STAGES[a.stage] || "starting"} · ${(a.elapsed_ms / 1000).toFixed(1)} s${eta}`;
    state.busySeen = [...state.busySeen.slice(-19), busy.textContent]; // (for the browser test)
  }
}

// ---- scene and controls -------------------------------------------------------------------
function onScene(e) {
  state.scene = e;
  $("title").textContent = e.name;
  if (!state.server?.camera) state.camera = { ...e.camera };
  $("time-controls").hidden = !e.animated;
  $("time").max = e.duration || 10;
  const select = $("light");
  select.replaceChildren(...e.lights.map((l) => new Option(`${l.name} (${l.kind})`, l.name)));
  $("light-controls").hidden = e.lights.length === 0;
  if (!e.lights.some((l) => l.name === state.selected)) state.selected = e.lights.length ? e.lights[0].name : null;
  select.value = state.selected ?? "";
  showParams(e.params);
  showCamera();
  showLight();
}

// The script's refrakt.param{…}s as sliders; moving one runs the script again with the value.
function showParams(params) {
  const box = $("param-controls");
  box.hidden = params.length === 0;
  box.replaceChildren(...params.map((p) => {
    const label = document.createElement("label");
    const value = state.params[p.name] ?? p.value;
    const input = Object.assign(document.createElement("input"), { type: "range", min: p.min, max: p.max, step: p.step, value });
    const out = Object.assign(document.createElement("output"), { textContent: value });
    input.dataset.param = p.name;
    input.addEventListener("input", () => {
      out.textContent = input.value;
      state.params[p.name] = Number(input.value);
      send(`param:${p.name}`, { type: "param", name: p.name, value: Number(input.value) });
    });
    label.append(`${p.name} `, input, " ", out);
    return label;
  }));
}

function sceneLight(name) { return state.scene?.lights.find((l) => l.name === name); }
// A light as shown: the scene's, with the edits on top.
function light(name) {
  const l = sceneLight(name);
  return l && { ...l, ...(state.lights[name] || {}) };
}

function editLight(name, edit) {
  state.lights[name] = { ...(state.lights[name] || {}), ...edit };
  send(`light:${name}`, { type: "light", name, ...state.lights[name] });
  showLight();
  redraw();
}

// Numeric fields: three inputs for a vector (x y z) or one for a number.
const fields = (prefix) => [0, 1, 2].map((i) => $(`${prefix}-${"xyz"[i]}`));
const round = (v) => +Number(v).toFixed(4);
function showVector(prefix, v) {
  fields(prefix).forEach((f, i) => { if (document.activeElement !== f) f.value = round(v[i]); });
}
const readVector = (prefix) => fields(prefix).map((f) => Number(f.value));

function showLight() {
  const l = state.selected && light(state.selected);
  if (!l) return;
  $("intensity").value = l.intensity ?? 1;
  $("intensity-value").textContent = Number(l.intensity ?? 1).toFixed(2);
  $("color").value = toHex(l.color);
  showVector("light-position", l.position);
  showVector("light-direction", l.direction);
  $("light-direction-row").hidden = l.kind === "point";
  $("light-position-row").hidden = l.kind === "sun";
}

function showCamera() {
  const c = state.camera;
  if (!c) return;
  showVector("camera-position", c.position);
  showVector("camera-target", c.target);
  if (document.activeElement !== $("camera-fov")) $("camera-fov").value = round(c.fov);
}

const toHex = (c) => "#" + c.map((v) => Math.round(255 * Math.pow(Math.min(1, Math.max(0, v)), 1 / 2.2)).toString(16).padStart(2, "0")).join("");
const fromHex = (h) => [1, 3, 5].map((i) => Math.pow(parseInt(h.slice(i, i + 2), 16) / 255, 2.2));

function sendDisplay() {
  $("exposure-value").textContent = $("exposure").value;
  send("display", { type: "display", layer: $("layer").value, exposure: Number($("exposure").value), tonemap: $("tonemap").value, quality: 85 });
}
["layer", "exposure", "tonemap"].forEach((id) => $(id).addEventListener("input", sendDisplay));

$("light").addEventListener("change", () => { state.selected = $("light").value; showLight(); redraw(); });
$("intensity").addEventListener("input", () => {
  $("intensity-value").textContent = Number($("intensity").value).toFixed(2);
  if (state.selected) editLight(state.selected, { intensity: Number($("intensity").value) });
});
$("color").addEventListener("input", () => state.selected && editLight(state.selected, { color: fromHex($("color").value) }));
for (const [prefix, key] of [["light-position", "position"], ["light-direction", "direction"]]) {
  fields(prefix).forEach((f) => f.addEventListener("change", () => {
    const v = readVector(prefix);
    if (state.selected && v.every(Number.isFinite)) editLight(state.selected, { [key]: v });
  }));
}
for (const id of ["camera-position-x", "camera-position-y", "camera-position-z", "camera-target-x", "camera-target-y", "camera-target-z", "camera-fov"]) {
  $(id).addEventListener("change", () => {
    if (!state.camera) return;
    const c = { position: readVector("camera-position"), target: readVector("camera-target"), fov: Number($("camera-fov").value) };
    if ([...c.position, ...c.target, c.fov].every(Number.isFinite)) { state.camera = c; sendCamera(); }
  });
}
$("light-reset").addEventListener("click", () => {
  if (!state.selected) return;
  delete state.lights[state.selected];
  send(`light:${state.selected}`, { type: "light", name: state.selected, reset: true });
  showLight();
  redraw();
});

function setTime(t) {
  state.time = t;
  $("time").value = t;
  $("time-value").textContent = t.toFixed(2);
  send("time", { type: "time", time: t });
}
$("time").addEventListener("input", () => setTime(Number($("time").value)));
$("play").addEventListener("click", () => {
  state.playing = !state.playing;
  $("play").textContent = state.playing ? "Pause" : "Play";
  let before = performance.now();
  const step = (now) => {
    if (!state.playing) return;
    const max = Number($("time").max);
    setTime((state.time + (now - before) / 1000) % max);
    before = now;
    requestAnimationFrame(step);
  };
  requestAnimationFrame(step);
});

$("camera-reset").addEventListener("click", () => {
  state.camera = { ...state.scene.camera };
  send("camera", { type: "camera", camera: null });
  showCamera();
});
$("undo").addEventListener("click", () => ask({ type: "undo" }));
$("redo").addEventListener("click", () => ask({ type: "redo" }));
document.addEventListener("keydown", (e) => {
  if (!(e.ctrlKey || e.metaKey) || e.target.tagName === "INPUT") return;
  const key = e.key.toLowerCase();
  if (key === "z" || key === "y") {
    e.preventDefault();
    ask({ type: key === "y" || e.shiftKey ? "redo" : "undo" });
  }
});
// The shown frame as a PNG, named after the scene, the frame's own time and its number.
$("save").addEventListener("click", () => {
  const h = state.last;
  if (!h) return;
  film.toBlob((blob) => {
    const a = document.createElement("a");
    a.href = URL.createObjectURL(blob);
    a.download = `${(state.scene?.name || "refrakt").replace(/\.[^.]*$/, "")}.t${h.time.toFixed(2)}s.frame${h.frame}.${h.layer}.png`;
    a.click();
    setTimeout(() => URL.revokeObjectURL(a.href), 1000);
  }, "image/png");
});
$("copy").addEventListener("click", () => ask({ type: "lua" }));
function showLua(text) {
  $("lua").textContent = text;
  navigator.clipboard?.writeText(text).catch(() => { /* shown below the button instead */ });
}
$("probe-button").addEventListener("click", () => {
  state.probing = !state.probing;
  $("probe-button").textContent = state.probing ? "Stop reading values" : "Read HDR values";
  $("probe").textContent = state.probing ? "point at the image" : "";
});

// ---- camera and light geometry ---------------------------------------------------------------
const sub = (a, b) => a.map((v, i) => v - b[i]);
const add = (a, b) => a.map((v, i) => v + b[i]);
const scale = (a, k) => a.map((v) => v * k);
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => scale(a, 1 / Math.hypot(...a));

function basis(c) {
  const forward = norm(sub(c.target, c.position));
  const right = norm(cross(forward, Math.abs(forward[1]) > 0.999 ? [0, 0, 1] : [0, 1, 0]));
  return { forward, right, up: cross(right, forward), t: Math.tan((c.fov * Math.PI) / 360), aspect: canvas.width / canvas.height };
}

// A world point → canvas pixels and depth along the axis.
function project(p) {
  const c = state.camera, b = basis(c), d = sub(p, c.position), z = dot(d, b.forward);
  if (z <= 1e-4) return null;
  const x = dot(d, b.right) / (z * b.t * b.aspect), y = dot(d, b.up) / (z * b.t);
  return { x: ((x + 1) / 2) * canvas.width, y: ((1 - y) / 2) * canvas.height, z };
}

// Canvas pixels at depth z → a world point.
function unproject(px, py, z) {
  const c = state.camera, b = basis(c);
  const x = (2 * px) / canvas.width - 1, y = 1 - (2 * py) / canvas.height;
  return add(c.position, add(scale(b.forward, z), add(scale(b.right, x * z * b.t * b.aspect), scale(b.up, y * z * b.t))));
}

function drawLights() {
  if (!state.scene || !state.camera) return;
  for (const l0 of state.scene.lights) {
    const l = light(l0.name);
    if (l.kind === "sun") continue;
    const p = project(l.position);
    if (!p) continue;
    ctx2d.beginPath();
    ctx2d.arc(p.x, p.y, 6, 0, 2 * Math.PI);
    ctx2d.fillStyle = toHex(l.color);
    ctx2d.fill();
    ctx2d.lineWidth = 2;
    ctx2d.strokeStyle = l.name === state.selected ? "#ffcc00" : "#000";
    ctx2d.stroke();
  }
}

function sendCamera() {
  send("camera", { type: "camera", camera: state.camera });
  showCamera();
  redraw();
}

function orbit(dx, dy) {
  const c = state.camera, off = sub(c.position, c.target), r = Math.hypot(...off);
  let theta = Math.atan2(off[0], off[2]) - dx * 0.008;
  let phi = Math.asin(Math.max(-1, Math.min(1, off[1] / r))) + dy * 0.008;
  phi = Math.max(-1.55, Math.min(1.55, phi));
  c.position = add(c.target, [r * Math.cos(phi) * Math.sin(theta), r * Math.sin(phi), r * Math.cos(phi) * Math.cos(theta)]);
  sendCamera();
}

function pan(dx, dy) {
  const c = state.camera, b = basis(c), r = Math.hypot(...sub(c.position, c.target));
  const k = (2 * r * b.t) / canvas.clientHeight;
  const move = add(scale(b.right, -dx * k), scale(b.up, dy * k));
  c.position = add(c.position, move);
  c.target = add(c.target, move);
  sendCamera();
}

function zoom(factor) {
  const c = state.camera;
  c.position = add(c.target, scale(sub(c.position, c.target), Math.max(0.05, factor)));
  sendCamera();
}

function turnLight(name, dx, dy) {
  const l = light(name);
  const d = l.direction;
  let theta = Math.atan2(d[0], d[2]) - dx * 0.008;
  let phi = Math.asin(Math.max(-1, Math.min(1, d[1]))) - dy * 0.008;
  phi = Math.max(-1.57, Math.min(1.57, phi));
  editLight(name, { direction: [Math.cos(phi) * Math.sin(theta), Math.sin(phi), Math.cos(phi) * Math.cos(theta)] });
}

// ---- pointer input -------------------------------------------------------------------------
const pointers = new Map();
let drag = null;

function canvasXY(e) {
  const r = canvas.getBoundingClientRect();
  return [((e.clientX - r.left) * canvas.width) / r.width, ((e.clientY - r.top) * canvas.height) / r.height];
}

function pickLight(x, y) {
  if (!state.scene) return null;
  for (const l0 of state.scene.lights) {
    const l = light(l0.name);
    if (l.kind === "sun") continue;
    const p = project(l.position);
    if (p && Math.hypot(p.x - x, p.y - y) < 12) return { name: l.name, z: p.z };
  }
  return null;
}

canvas.addEventListener("contextmenu", (e) => e.preventDefault());
canvas.addEventListener("pointerdown", (e) => {
  if (!state.camera) return;
  canvas.setPointerCapture(e.pointerId);
  pointers.set(e.pointerId, [e.clientX, e.clientY]);
  const [x, y] = canvasXY(e);
  const picked = pickLight(x, y);
  if (picked) {
    state.selected = picked.name;
    $("light").value = picked.name;
    showLight();
  }
  const mode = picked ? "light" : e.altKey && state.selected ? "turn" : e.button === 2 || e.shiftKey ? "pan" : "orbit";
  drag = { mode, picked, x: e.clientX, y: e.clientY, pinch: null };
});
canvas.addEventListener("pointermove", (e) => {
  const p = canvasXY(e);
  probe(p);
  if (!drag || !pointers.has(e.pointerId)) return;
  pointers.set(e.pointerId, [e.clientX, e.clientY]);
  if (pointers.size === 2) {
    const [a, b] = [...pointers.values()];
    const d = Math.hypot(a[0] - b[0], a[1] - b[1]);
    if (drag.pinch) zoom(drag.pinch / d);
    drag.pinch = d;
    return;
  }
  const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
  drag.x = e.clientX;
  drag.y = e.clientY;
  if (drag.mode === "orbit") orbit(dx, dy);
  else if (drag.mode === "pan") pan(dx, dy);
  else if (drag.mode === "turn") turnLight(state.selected, dx, dy);
  else if (drag.mode === "light") editLight(drag.picked.name, { position: unproject(p[0], p[1], drag.picked.z) });
});
const release = (e) => {
  pointers.delete(e.pointerId);
  if (pointers.size === 0) drag = null;
};
canvas.addEventListener("pointerup", release);
canvas.addEventListener("pointercancel", release);
canvas.addEventListener("wheel", (e) => { e.preventDefault(); if (state.camera) zoom(Math.exp(e.deltaY * 0.001)); }, { passive: false });

// The linear values under the cursor, asked of the server for that one pixel of the shown frame.
let probeAsked = false;
function probe([x, y]) {
  if (!state.probing || !state.last || probeAsked) return;
  const px = Math.floor(x), py = Math.floor(y);
  if (px < 0 || py < 0 || px >= state.last.width || py >= state.last.height) return;
  probeAsked = true;
  requestAnimationFrame(() => { probeAsked = false; ask({ type: "hdr", region: [px, py, 1, 1] }); });
}
function showProbe(header, values) {
  const [x, y] = header.region;
  $("probe").textContent = `${header.layer} at (${x}, ${y}): ${Array.from(values, (f) => f.toPrecision(4)).join(", ")}`;
}

connect();
