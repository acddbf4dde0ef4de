#include "server/service/live/live_page.h"

namespace waymark::service::live {
namespace {

// Kept small and dependency-free on purpose: it is for people without Foxglove. Everything it
// shows comes over the WebSocket, in the channels' JSON (docs/live-view.md).
constexpr absl::string_view kPage = R"html(<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>Waymark live view</title>
<style>
  body { margin: 0; font: 14px system-ui, sans-serif; display: flex; height: 100vh; background: #f4f4f4; }
  #side { width: 260px; padding: 10px; overflow-y: auto; background: #fff; border-right: 1px solid #ccc; }
  #side h1 { font-size: 16px; margin: 0 0 8px; }
  #sessions div { padding: 6px; margin: 2px 0; border-radius: 4px; cursor: pointer; }
  #sessions div.chosen { background: #dde8ff; }
  #status { color: #666; font-size: 12px; margin-bottom: 8px; }
  #confidence { margin-top: 12px; font-size: 13px; white-space: pre-line; }
  #main { flex: 1; position: relative; }
  canvas { width: 100%; height: 100%; display: block; }
</style>
</head>
<body>
<div id="side">
  <h1>Waymark live view</h1>
  <div id="status">connecting...</div>
  <div id="sessions"></div>
  <div id="confidence"></div>
</div>
<div id="main"><canvas id="map"></canvas></div>
<script>
"use strict";
const params = new URLSearchParams(location.search);
const token = params.get("token");
const wsUrl = (location.protocol === "https:" ? "wss://" : "ws://") + location.host + "/" +
  (token ? "?token=" + encodeURIComponent(token) : "");
const byTopic = new Map();   // topic -> channel
const subs = new Map();      // subscription id -> topic
const subOfTopic = new Map();
let nextSub = 1, ws = null, chosen = params.get("session"), sessions = [];
// ?zoom=PIXELS_PER_M keeps a fixed scale around the map's origin (0, 0); the default fits the map.
const zoom = Number(params.get("zoom")) || 0;
const view = { grid: null, gridImage: null, pose: null, scan: null, trajectory: null, confidence: null };
const canvas = document.getElementById("map");
const ctx = canvas.getContext("2d");
const statusEl = document.getElementById("status");
// For tests and scripts: what the page has drawn so far.
window.waymarkLive = { grids: 0, poses: 0, drawnCells: 0, session: null };

function send(msg) { if (ws && ws.readyState === 1) ws.send(JSON.stringify(msg)); }
function subscribe(topic) {
  const ch = byTopic.get(topic);
  if (!ch || subOfTopic.has(topic)) return;
  const id = nextSub++;
  subs.set(id, topic); subOfTopic.set(topic, id);
  send({ op: "subscribe", subscriptions: [{ id: id, channelId: ch.id }] });
}
function unsubscribeAll(prefix) {
  const ids = [];
  for (const [topic, id] of subOfTopic) if (topic.startsWith(prefix)) { ids.push(id); subOfTopic.delete(topic); subs.delete(id); }
  if (ids.length) send({ op: "unsubscribe", subscriptionIds: ids });
}
function choose(id) {
  if (chosen && chosen !== id) unsubscribeAll("/sessions/" + chosen + "/");
  chosen = id; window.waymarkLive.session = id;
  Object.assign(view, { grid: null, gridImage: null, pose: null, scan: null, trajectory: null, confidence: null });
  for (const kind of ["grid", "trajectory", "scan", "pose", "confidence"]) subscribe("/sessions/" + id + "/" + kind);
  renderSessions(); draw();
}
function renderSessions() {
  const el = document.getElementById("sessions");
  el.textContent = "";
  if (!sessions.length) { el.textContent = "no open session"; return; }
  for (const s of sessions) {
    const d = document.createElement("div");
    d.textContent = (s.name || s.session_id) + " - " + s.robot_id + " (" + s.kind + ", " + s.scans_processed + " scans)";
    if (s.session_id === chosen) d.className = "chosen";
    d.onclick = () => choose(s.session_id);
    el.appendChild(d);
  }
}
function timeOf(t) { return t ? t.sec + t.nsec * 1e-9 : 0; }
function yawOf(q) { return Math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z)); }
function gridToImage(g) {
  const raw = atob(g.data), w = g.column_count, h = raw.length / g.row_stride;
  const img = new ImageData(w, h);
  let drawn = 0;
  for (let row = 0; row < h; ++row) for (let col = 0; col < w; ++col) {
    let v = raw.charCodeAt(row * g.row_stride + col * g.cell_stride);
    if (v > 127) v -= 256;
    const shade = v < 0 ? 205 : Math.round(255 - v * 2.55);
    if (v >= 0) ++drawn;
    const o = ((h - 1 - row) * w + col) * 4;  // grid rows run up, image rows down
    img.data[o] = img.data[o + 1] = img.data[o + 2] = shade; img.data[o + 3] = 255;
  }
  window.waymarkLive.drawnCells = drawn;
  const c = document.createElement("canvas"); c.width = w; c.height = h;
  c.getContext("2d").putImageData(img, 0, 0);
  return { canvas: c, w: w, h: h };
}
function bounds() {
  let b = null;
  const add = (x, y) => { if (!b) b = { x0: x, x1: x, y0: y, y1: y }; b.x0 = Math.min(b.x0, x); b.x1 = Math.max(b.x1, x); b.y0 = Math.min(b.y0, y); b.y1 = Math.max(b.y1, y); };
  if (view.grid) { const p = view.grid.pose.position; add(p.x, p.y); add(p.x + view.gridImage.w * view.grid.cell_size.x, p.y + view.gridImage.h * view.grid.cell_size.y); }
  if (view.trajectory) for (const p of view.trajectory.poses) add(p.position.x, p.position.y);
  if (view.pose) add(view.pose.pose.position.x, view.pose.pose.position.y);
  if (!b) return null;
  const m = 1.0; b.x0 -= m; b.y0 -= m; b.x1 += m; b.y1 += m;
  return b;
}
function draw() {
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
  ctx.fillStyle = "#cdcdcd"; ctx.fillRect(0, 0, w, h);
  let b = bounds();
  if (!b) return;
  let s = Math.min(w / (b.x1 - b.x0), h / (b.y1 - b.y0));
  if (zoom > 0) { s = zoom; b = { x0: -w / 2 / s, y0: -h / 2 / s }; }
  const X = (x) => (x - b.x0) * s, Y = (y) => h - (y - b.y0) * s;
  if (view.grid) {
    const p = view.grid.pose.position, cw = view.grid.cell_size.x, ch = view.grid.cell_size.y;
    ctx.imageSmoothingEnabled = false;
    ctx.drawImage(view.gridImage.canvas, X(p.x), Y(p.y + view.gridImage.h * ch), view.gridImage.w * cw * s, view.gridImage.h * ch * s);
  }
  if (view.trajectory && view.trajectory.poses.length) {
    ctx.strokeStyle = "#1f6feb"; ctx.lineWidth = 2; ctx.beginPath();
    view.trajectory.poses.forEach((p, i) => { const f = i ? ctx.lineTo : ctx.moveTo; f.call(ctx, X(p.position.x), Y(p.position.y)); });
    ctx.stroke();
  }
  if (view.scan) {
    const sp = view.scan.pose, yaw = yawOf(sp.orientation), n = view.scan.ranges.length;
    const step = n > 1 ? (view.scan.end_angle - view.scan.start_angle) / (n - 1) : 0;
    ctx.fillStyle = "#e5534b";
    view.scan.ranges.forEach((r, i) => {
      if (!(r > 0)) return;
      const a = yaw + view.scan.start_angle + i * step;
      ctx.fillRect(X(sp.position.x + r * Math.cos(a)) - 1, Y(sp.position.y + r * Math.sin(a)) - 1, 2, 2);
    });
  }
  if (view.pose) {
    const p = view.pose.pose.position, yaw = yawOf(view.pose.pose.orientation), r = 10;
    ctx.save(); ctx.translate(X(p.x), Y(p.y)); ctx.rotate(-yaw);
    ctx.fillStyle = "#2da44e"; ctx.beginPath(); ctx.moveTo(r, 0); ctx.lineTo(-r * 0.7, r * 0.6); ctx.lineTo(-r * 0.7, -r * 0.6); ctx.closePath(); ctx.fill();
    ctx.restore();
  }
}
function showConfidence(c) {
  const lines = [];
  if (c.sigma_x !== undefined) lines.push("sigma x " + c.sigma_x.toFixed(3) + " m, y " + c.sigma_y.toFixed(3) + " m, theta " + (c.sigma_theta * 180 / Math.PI).toFixed(2) + " deg");
  if (c.localization) lines.push("localization: " + (c.localization.state || (c.localization.localized ? "TRACKING" : "not localized")) + (c.localization.score !== undefined ? ", score " + Number(c.localization.score).toFixed(2) : ""));
  if (c.tracking) lines.push("tracking: " + (c.tracking.level || "") + " " + (c.tracking.reason || ""));
  if (c.matched_segments !== undefined) lines.push("segments matched " + c.matched_segments + " of " + c.observed_segments + " seen");
  document.getElementById("confidence").textContent = lines.join("\n");
}
function onMessage(topic, msg) {
  if (topic === "/sessions") {
    sessions = msg.sessions;
    if ((!chosen || !sessions.some(s => s.session_id === chosen)) && sessions.length) choose(sessions[0].session_id);
    else { for (const s of sessions) if (s.session_id === chosen) for (const t of s.topics) if (/\/(grid|trajectory|scan|pose|confidence)$/.test(t)) subscribe(t); renderSessions(); }
    return;
  }
  if (!chosen || !topic.startsWith("/sessions/" + chosen + "/")) return;
  const kind = topic.slice(topic.lastIndexOf("/") + 1);
  if (kind === "grid") { view.grid = msg; view.gridImage = gridToImage(msg); window.waymarkLive.grids++; }
  else if (kind === "pose") { view.pose = msg; window.waymarkLive.poses++; }
  else if (kind === "scan") view.scan = msg;
  else if (kind === "trajectory") view.trajectory = msg;
  else if (kind === "confidence") { view.confidence = msg; showConfidence(msg); }
  scheduleDraw();
}
let drawPending = false;
function scheduleDraw() { if (!drawPending) { drawPending = true; requestAnimationFrame(() => { drawPending = false; draw(); }); } }
const decoder = new TextDecoder();
function connect() {
  ws = new WebSocket(wsUrl, ["foxglove.websocket.v1"]);
  ws.binaryType = "arraybuffer";
  ws.onopen = () => { statusEl.textContent = "connected"; };
  ws.onclose = (e) => { statusEl.textContent = "disconnected (" + (e.code || "") + "); retrying..."; byTopic.clear(); subs.clear(); subOfTopic.clear(); setTimeout(connect, 2000); };
  ws.onmessage = (e) => {
    if (typeof e.data === "string") {
      const m = JSON.parse(e.data);
      if (m.op === "advertise") { for (const c of m.channels) byTopic.set(c.topic, c); subscribe("/sessions"); if (chosen) for (const c of m.channels) if (c.topic.startsWith("/sessions/" + chosen + "/") && /\/(grid|trajectory|scan|pose|confidence)$/.test(c.topic)) subscribe(c.topic); }
      else if (m.op === "unadvertise") { for (const id of m.channelIds) for (const [t, c] of byTopic) if (c.id === id) { byTopic.delete(t); const s = subOfTopic.get(t); if (s !== undefined) { subOfTopic.delete(t); subs.delete(s); } } }
      else if (m.op === "status") statusEl.textContent = m.message;
      return;
    }
    const dv = new DataView(e.data);
    if (dv.getUint8(0) !== 1) return;
    const topic = subs.get(dv.getUint32(1, true));
    if (topic === undefined) return;
    onMessage(topic, JSON.parse(decoder.decode(new Uint8Array(e.data, 13))));
  };
}
window.addEventListener("resize", scheduleDraw);
connect();
</script>
</body>
</html>
)html";

}  // namespace

absl::string_view LivePage() { return kPage; }

}  // namespace waymark::service::live
