// refrakt serve's page: shows the frames the server sends and sends the user's edits.
// Protocol: src/serve/protocol.rs. Edits are sent at most once per animation frame (the server
// keeps only the newest state anyway).
"use strict";

const $ = (id) => document.getElementById(id);
const canvas = $("frame");
const ctx2d = canvas.getContext("2d");
// The frame as received, without the lights' dots drawn over it ("save still" saves this).
const film = document.createElement("canvas");
const filmCtx = film.getContext("2d");
const token = new URLSearchParams(location.search).get("token");
const state = {
  scene: null, camera: null, lights: {}, selected: null, time: 0, playing: false,
  frames: 0, last: null, arrivals: [], hdr: null, nextId: 1, outbox: new Map(),
};
window.refrakt = state; // for the browser test and the curious

// ---- connection -------------------------------------------------------------------------
let socket;
function connect() {
  const url = `ws://${location.host}/ws${token ? `?token=${encodeURIComponent(token)}` : ""}`;
  socket = new WebSocket(url);
  socket.binaryType = "arraybuffer";
  socket.onopen = () => { $("stats").textContent = "connected, waiting for the first frame…"; flush(); };
  socket.onclose = () => { $("stats").textContent = "disconnected; retrying…"; setTimeout(connect, 1000); };
  socket.onmessage = (m) => (typeof m.data === "string" ? onEvent(JSON.parse(m.data)) : onFrame(m.data));
}

// Queues a message by kind (and light name): a newer one of the same kind replaces it.
function send(key, message) {
  state.outbox.set(key, { ...message, id: state.nextId++ });
  requestAnimationFrame(flush);
}
function flush() {
  if (!socket || socket.readyState !== WebSocket.OPEN) return;
  for (const m of state.outbox.values()) socket.send(JSON.stringify(m));
  state.outbox.clear();
}

function onEvent(e) {
  if (e.type === "scene") onScene(e);
  else if (e.type === "error") showError(e.message);
  else if (e.type === "ok") showError(null);
  else if (e.type === "warning") console.warn(e.message);
}

function showError(message) {
  $("error").hidden = !message;
  $("error").textContent = message ? `${message}\n(the last good frame stays; save a fix to render again)` : "";
}

async function onFrame(buffer) {
  const view = new DataView(buffer);
  const length = view.getUint32(0, true);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, length)));
  const payload = new Uint8Array(buffer, 4 + length);
  if (header.kind === "hdr") {
    state.hdr = { header, values: new Float32Array(payload.slice().buffer) };
    $("probe").textContent = "HDR values loaded: point at the image";
    return;
  }
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
  ctx2d.drawImage(film, 0, 0);
  drawLights();
  state.frames += 1;
  state.last = header;
  const now = performance.now();
  state.arrivals.push(now);
  while (state.arrivals.length && state.arrivals[0] < now - 1000) state.arrivals.shift();
  showStats(header, now);
}

function showStats(h, now) {
  const t = h.times;
  const gpu = t.gpu.map(([stage, ms]) => `${stage} ${ms.toFixed(2)}`).join(", ");
  const reused = [h.reused.volume && "volume", h.reused.photons && "photons"].filter(Boolean).join(" + ") || "nothing";
  const delivered = Math.max(0, Date.now() - h.ready_us / 1000);
  $("stats").textContent =
    `${state.arrivals.length} fps · frame ${h.frame} ${h.width}×${h.height} · reused ${reused}\n` +
    `render ${t.render_ms.toFixed(1)} ms · readback ${t.readback_ms.toFixed(1)} · encode ${t.encode_ms.toFixed(1)} · ` +
    `scene ${t.scene_ms.toFixed(1)} · delivery ${delivered.toFixed(1)} ms\nGPU ms: ${gpu || "(no timestamps on this adapter)"}`;
}

// ---- scene and controls -------------------------------------------------------------------
function onScene(e) {
  const first = !state.scene;
  state.scene = e;
  $("title").textContent = e.name;
  if (first) state.camera = { ...e.camera };
  $("time-controls").hidden = !e.animated;
  const select = $("light");
  select.replaceChildren(...e.lights.map((l) => new Option(`${l.name} (${l.kind})`, l.name)));
  $("light-controls").hidden = e.lights.length === 0;
  if (!e.lights.some((l) => l.name === state.selected)) state.selected = e.lights.length ? e.lights[0].name : null;
  select.value = state.selected ?? "";
  showParams(e.params);
  showLight();
  showLua();
}

// The script's refrakt.param{…}s as sliders; moving one runs the script again with the value.
function showParams(params) {
  const box = $("param-controls");
  box.hidden = params.length === 0;
  box.replaceChildren(...params.map((p) => {
    const label = document.createElement("label");
    const input = Object.assign(document.createElement("input"), { type: "range", min: p.min, max: p.max, step: p.step, value: p.value });
    const out = Object.assign(document.createElement("output"), { textContent: p.value });
    input.dataset.param = p.name;
    input.addEventListener("input", () => {
      out.textContent = input.value;
      send(`param:${p.name}`, { type: "param", name: p.name, value: Number(input.value) });
    });
    label.append(`${p.name} `, input, " ", out);
    return label;
  }));
}

function sceneLight(name) { return state.scene?.lights.find((l) => l.name === name); }
// A light as shown: the scene's, with the page's edits on top.
function light(name) {
  const l = sceneLight(name);
  return l && { ...l, ...(state.lights[name] || {}) };
}

function editLight(name, edit) {
  state.lights[name] = { ...(state.lights[name] || {}), ...edit };
  send(`light:${name}`, { type: "light", name, ...state.lights[name] });
  drawLights();
}

function showLight() {
  const l = state.selected && light(state.selected);
  if (!l) return;
  $("intensity").value = l.intensity ?? 1;
  $("intensity-value").textContent = Number(l.intensity ?? 1).toFixed(2);
  $("color").value = toHex(l.color);
}

const toHex = (c) => "#" + c.map((v) => Math.round(255 * Math.pow(Math.min(1, Math.max(0, v)), 1 / 2.2)).toString(16).padStart(2, "0")).join("");
const fromHex = (h) => [1, 3, 5].map((i) => Math.pow(parseInt(h.slice(i, i + 2), 16) / 255, 2.2));

function sendDisplay() {
  $("exposure-value").textContent = $("exposure").value;
  send("display", { type: "display", layer: $("layer").value, exposure: Number($("exposure").value), tonemap: $("tonemap").value, quality: 85 });
}
["layer", "exposure", "tonemap"].forEach((id) => $(id).addEventListener("input", sendDisplay));

$("light").addEventListener("change", () => { state.selected = $("light").value; showLight(); drawLights(); });
$("intensity").addEventListener("input", () => {
  $("intensity-value").textContent = Number($("intensity").value).toFixed(2);
  if (state.selected) editLight(state.selected, { intensity: Number($("intensity").value) });
});
$("color").addEventListener("input", () => state.selected && editLight(state.selected, { color: fromHex($("color").value) }));
$("light-reset").addEventListener("click", () => {
  if (!state.selected) return;
  delete state.lights[state.selected];
  send(`light:${state.selected}`, { type: "light", name: state.selected, reset: true });
  showLight();
  drawLights();
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
  showLua();
});
$("save").addEventListener("click", () => {
  if (!state.frames) return;
  film.toBlob((blob) => {
    const a = document.createElement("a");
    a.href = URL.createObjectURL(blob);
    a.download = `${(state.scene?.name || "refrakt").replace(/\.[^.]*$/, "")}.t${state.time.toFixed(2)}s.png`;
    a.click();
    setTimeout(() => URL.revokeObjectURL(a.href), 1000);
  }, "image/png");
});
$("copy").addEventListener("click", async () => {
  const text = showLua();
  try { await navigator.clipboard.writeText(text); } catch { /* shown below the button instead */ }
});
$("hdr").addEventListener("click", () => socket?.readyState === WebSocket.OPEN && socket.send(JSON.stringify({ type: "hdr" })));

function showLua() {
  const c = state.camera, s = state.scene;
  if (!c || !s) return "";
  const v = (a) => `{${a.map((x) => +x.toFixed(4)).join(", ")}}`;
  const text = `camera = r.camera{ position = ${v(c.position)}, target = ${v(c.target)}, fov = ${+c.fov.toFixed(3)}, size = {${s.size[0]}, ${s.size[1]}} },`;
  $("lua").textContent = text;
  return text;
}

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
  showLua();
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

// The linear value under the cursor, from the last HDR frame.
function probe([x, y]) {
  const h = state.hdr;
  if (!h) return;
  const { width, height, channels, layer } = h.header;
  const i = Math.floor(y) * width + Math.floor(x);
  if (x < 0 || y < 0 || x >= width || y >= height) return;
  const v = Array.from(h.values.slice(i * channels, (i + 1) * channels), (f) => f.toPrecision(4));
  $("probe").textContent = `${layer} at (${Math.floor(x)}, ${Math.floor(y)}): ${v.join(", ")}`;
}

connect();
