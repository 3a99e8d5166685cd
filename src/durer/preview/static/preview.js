// durer preview: shows the frames the server streams over a WebSocket and sends it the mouse's moves.
// No libraries, nothing downloaded: the server does all the rendering, projection and ray-tree work.
"use strict";

const $ = (id) => document.getElementById(id);
const image = $("image"), overlay = $("overlay"), stage = $("stage");
const COLORS = { camera: "#ffffff", shadow: "#28dc28", blocked: "#145a14", reflection: "#ff3232",
                 refraction: "#3c8cff", bounce: "#ffa028" };
let ws = null, state = null, tree = null, zoomScale = 1, frameSeq = 0;

function send(message) { if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(message)); }

function connect() {
  const url = (location.protocol === "https:" ? "wss://" : "ws://") + location.host +
    location.pathname.replace(/[^/]*$/, "") + "ws";
  ws = new WebSocket(url);
  ws.onmessage = (event) => receive(JSON.parse(event.data));
  ws.onclose = () => { $("status").textContent = "disconnected: is `durer preview` still running?"; };
}

function receive(m) {
  if (m.type === "state") showState(m);
  else if (m.type === "frame") showFrame(m);
  else if (m.type === "tree") { tree = m.tree ? m : null; showTree(); }
  else if (m.type === "error") showError(m.message);
  else if (m.type === "notice") { $("notice").textContent = m.message; }
}

function showState(m) {
  state = m;
  if ($("status").textContent.startsWith("connecting")) $("status").textContent = "rendering\u2026";
  document.body.dataset.camera = JSON.stringify(m.camera);
  document.body.dataset.generation = m.generation;
  if (image.width !== m.width || image.height !== m.height) {
    // show small images enlarged (whole pixels), big ones as they are; the rays are drawn at screen resolution
    zoomScale = Math.max(1, Math.floor(512 / Math.max(m.width, m.height)));
    image.width = m.width; image.height = m.height;
    overlay.width = m.width * zoomScale; overlay.height = m.height * zoomScale;
    for (const c of [image, overlay]) { c.style.width = m.width * zoomScale + "px"; c.style.height = m.height * zoomScale + "px"; }
    showTree();
  }
  for (const key of ["samples", "bounces"]) if (document.activeElement !== $(key)) $(key).value = m[key];
  $("shadows").checked = m.shadows;
  for (const key of ["bounces", "shadows"]) {  // the course's Whitted switches: the path tracer has max_depth instead
    $(key).disabled = m.integrator === "path";
    $(key).title = m.integrator === "path" ? "the path tracer follows the scene's max_depth" : "";
  }
  $("mode").value = m.mode;
  // the denoise toggle: off by default, disabled (the tooltip says why) without the path tracer or pyoidn
  $("denoise").checked = m.denoise;
  $("denoise").disabled = !!m.denoise_unavailable;
  $("denoise-label").title = m.denoise_unavailable ||
    "show the path-traced image denoised by Intel Open Image Denoise (albedo and normals from the same samples)";
}

function showFrame(m) {
  const seq = ++frameSeq;
  const img = new Image();
  img.onload = () => {
    if (seq !== frameSeq) return;  // a newer frame arrived while this one decoded
    const ctx = image.getContext("2d");
    ctx.imageSmoothingEnabled = false;
    ctx.drawImage(img, 0, 0, m.width, m.height);
    image.dataset.generation = m.generation;
    image.dataset.level = m.level;
    image.dataset.mode = m.mode;
    image.dataset.final = m.final ? "1" : "0";
    image.dataset.samples = m.samples;
    image.dataset.denoised = m.denoised ? "1" : "0";
    image.dataset.camera = JSON.stringify(m.camera);  // the camera of the frame shown (the state's may be newer)
    document.body.dataset.camera = JSON.stringify(m.camera);
    $("status").textContent = `${m.final ? "done" : "refining"}: ${m.frame_width}x${m.frame_height}` +
      `, ${m.samples} spp` + (m.denoised ? `, denoised (${m.denoise_seconds.toFixed(2)} s)` : "") +
      ` (level ${m.level + 1}/${m.levels}, ${m.seconds.toFixed(2)} s)`;
  };
  img.src = "data:image/png;base64," + m.png;
}

function showError(message) {
  const box = $("error");
  box.textContent = message || "";
  box.style.display = message ? "block" : "none";
}

function showTree() {
  const ctx = overlay.getContext("2d");
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.clearRect(0, 0, overlay.width, overlay.height);
  ctx.setTransform(zoomScale, 0, 0, zoomScale, 0, 0);  // image pixels -> overlay pixels
  const pre = $("tree");
  pre.textContent = "";
  if (!tree) { delete pre.dataset.pixel; return; }
  pre.dataset.pixel = JSON.stringify(tree.tree.pixel);
  for (const line of tree.text.split("\n")) {  // colour each line by its ray's kind
    const span = document.createElement("span");
    const word = line.trim().split(/\s/)[0];
    span.className = COLORS[word] ? "k-" + word : (line.startsWith("      ") ? "k-term" : "");
    span.textContent = line + "\n";
    pre.appendChild(span);
  }
  ctx.lineWidth = 2 / zoomScale;
  for (const [key, lines] of tree.overlay) {
    ctx.strokeStyle = COLORS[key];
    for (const points of lines) {
      ctx.beginPath();
      points.forEach(([x, y], i) => (i ? ctx.lineTo(x, y) : ctx.moveTo(x, y)));
      ctx.stroke();
    }
  }
  const [px, py] = tree.tree.pixel;
  ctx.strokeStyle = "#ffff00";
  ctx.strokeRect(px, py, 1, 1);
}

// --- the mouse: drag orbits (shift or right button pans), a click without a drag explains the pixel ---------
let drag = null, pending = null, timer = null;

function imagePoint(event) {
  const r = image.getBoundingClientRect();
  return [(event.clientX - r.left) * image.width / r.width, (event.clientY - r.top) * image.height / r.height];
}

function flush() {  // at most one camera move per 40 ms: the server restarts its progressive render each time
  timer = null;
  if (pending) { send(pending); pending = null; }
}

function queueMove(type, dx, dy) {
  if (pending && pending.type === type) { pending.dx += dx; pending.dy += dy; } else { flush(); pending = { type, dx, dy }; }
  if (!timer) timer = setTimeout(flush, 40);
}

stage.addEventListener("contextmenu", (e) => e.preventDefault());
stage.addEventListener("mousedown", (e) => {
  const [x, y] = imagePoint(e);
  drag = { x, y, startX: x, startY: y, pan: e.shiftKey || e.button === 2, moved: false };
  stage.style.cursor = "grabbing";
});
window.addEventListener("mousemove", (e) => {
  if (!drag) return;
  const [x, y] = imagePoint(e);
  if (Math.hypot(x - drag.startX, y - drag.startY) * zoomScale > 3) drag.moved = true;
  if (drag.moved) queueMove(drag.pan ? "pan" : "orbit", x - drag.x, y - drag.y);
  drag.x = x; drag.y = y;
});
window.addEventListener("mouseup", (e) => {
  if (!drag) return;
  stage.style.cursor = "grab";
  if (!drag.moved && e.button === 0) {
    const [x, y] = imagePoint(e);
    const px = Math.floor(x), py = Math.floor(y);
    if (px >= 0 && py >= 0 && px < image.width && py < image.height) send({ type: "explain", x: px, y: py });
  }
  flush();
  drag = null;
});
stage.addEventListener("wheel", (e) => {
  e.preventDefault();
  send({ type: "zoom", factor: Math.exp(Math.max(-1, Math.min(1, e.deltaY / 500))) });
}, { passive: false });

$("mode").addEventListener("change", () => send({ type: "set", mode: $("mode").value }));
$("samples").addEventListener("change", () => send({ type: "set", samples: parseInt($("samples").value, 10) }));
$("bounces").addEventListener("change", () => send({ type: "set", bounces: parseInt($("bounces").value, 10) }));
$("shadows").addEventListener("change", () => send({ type: "set", shadows: $("shadows").checked }));
$("denoise").addEventListener("change", () => send({ type: "set", denoise: $("denoise").checked }));
$("reset").addEventListener("click", () => send({ type: "reset" }));
$("clear").addEventListener("click", () => send({ type: "clear" }));
connect();
