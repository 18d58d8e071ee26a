// The live view's page: frames with overlays, the ground map and the plots, from /ws.
// Each frame is acknowledged once it is drawn, so the server sends no faster than this page
// draws. The socket reopens by itself (with a growing delay) when the rig goes away.
"use strict";

const HISTORY_S = 30;
const COLOURS = ["#4e79a7", "#f28e2b", "#59a14f", "#e15759", "#b07aa1", "#76b7b2", "#edc948"];

const view = {
  socket: null,
  frame: null, // {meta, image}
  state: null,
  framesShown: 0,
  overlaysDrawn: 0,
  selected: null, // the server's answer to the last click
  commanded: null, // the server's answer to the last button (park, search, hold, resume)
  models: [], // [{t, values: {name: p}}]
  latency: [], // [{t, values: {stage: ms}}]
  trails: new Map(), // track id -> [[x, y], ...]
  mapDrawn: { tracks: 0, predictions: 0, ellipses: 0 }, // what the last map showed
  retryMs: 250,
};
window.gazedView = view; // read by the browser test

const $ = (id) => document.getElementById(id);

function connect() {
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  const socket = new WebSocket(`${scheme}://${location.host}/ws`);
  socket.binaryType = "arraybuffer";
  view.socket = socket;
  socket.onopen = () => {
    view.retryMs = 250;
    setConnection("connected", true);
  };
  socket.onclose = () => {
    setConnection(`reconnecting in ${(view.retryMs / 1000).toFixed(1)} s`, false);
    setTimeout(connect, view.retryMs);
    view.retryMs = Math.min(view.retryMs * 2, 5000);
  };
  socket.onmessage = (event) => {
    if (typeof event.data === "string") onText(JSON.parse(event.data));
    else onFrame(event.data, socket);
  };
}

function setConnection(text, good) {
  const element = $("connection");
  element.textContent = text;
  element.className = good ? "good" : "bad";
}

function onFrame(buffer, socket) {
  const length = new DataView(buffer).getUint32(0);
  const meta = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, length)));
  const blob = new Blob([new Uint8Array(buffer, 4 + length)], { type: "image/jpeg" });
  const ack = () => {
    if (socket.readyState === WebSocket.OPEN) socket.send(JSON.stringify({ type: "ack", seq: meta.seq }));
  };
  createImageBitmap(blob)
    .then((image) => {
      if (view.frame) view.frame.image.close();
      view.frame = { meta, image };
      drawFrame();
      view.framesShown += 1;
    })
    .finally(ack);
}

function onText(message) {
  if (message.type === "state") {
    view.state = message;
    remember(message);
    showState(message);
    drawMap(message);
    plot($("models"), view.models, 0, 1);
    plot($("latency"), view.latency, 0, null);
  } else if (message.type === "selected") {
    view.selected = message;
    $("selected").textContent = message.ok ? message.message : `not selected: ${message.message}`;
  } else if (message.type === "commanded") {
    view.commanded = message;
    $("commanded").textContent = message.ok ? message.message : `not sent: ${message.message}`;
  }
}

function remember(state) {
  const t = performance.now() / 1000;
  if (Object.keys(state.models).length) view.models.push({ t, values: state.models });
  if (Object.keys(state.latency_ms).length) view.latency.push({ t, values: state.latency_ms });
  for (const series of [view.models, view.latency]) {
    while (series.length && series[0].t < t - HISTORY_S) series.shift();
  }
  for (const track of state.tracks) {
    const trail = view.trails.get(track.id) || [];
    trail.push(track.xy);
    if (trail.length > 300) trail.shift();
    view.trails.set(track.id, trail);
  }
  const live = new Set(state.tracks.map((track) => track.id));
  for (const id of view.trails.keys()) if (!live.has(id)) view.trails.delete(id);
}

function showState(state) {
  $("gaze-state").textContent = state.gaze ? state.gaze.state : "—";
  $("gaze-reason").textContent = state.gaze && state.gaze.reason ? `(${state.gaze.reason})` : "";
  $("target-id").textContent = state.target_id === null ? "—" : String(state.target_id);
  // the button of the state the head is in is lit (park and hold stay on until resume)
  const now = state.gaze ? state.gaze.state : null;
  for (const button of document.querySelectorAll("button[data-command]")) {
    button.setAttribute("aria-pressed", String(button.dataset.command === now));
  }
}

// -- the camera frame and its overlays -------------------------------------------------------

function drawFrame() {
  const { meta, image } = view.frame;
  const canvas = $("frame");
  if (canvas.width !== meta.width || canvas.height !== meta.height) {
    canvas.width = meta.width;
    canvas.height = meta.height;
  }
  const g = canvas.getContext("2d");
  g.drawImage(image, 0, 0);
  const o = meta.overlay;
  let drawn = 0;
  g.lineWidth = 1.5;
  g.font = "13px system-ui, sans-serif";
  const f = o.fovea;
  g.setLineDash([4, 4]);
  g.strokeStyle = "#888";
  g.strokeRect(f.u - f.side / 2, f.v - f.side / 2, f.side, f.side);
  g.setLineDash([]);
  for (const c of o.candidates) {
    circle(g, c.u, c.v, 6, "#6cf");
    drawn += 1;
  }
  for (const m of o.movers) {
    g.strokeStyle = "#fc3";
    const w = Math.max(m.w, 8);
    const h = Math.max(m.h, 8);
    g.strokeRect(m.u - w / 2, m.v - h / 2, w, h);
    drawn += 1;
  }
  if (o.detection && o.detection.found) {
    cross(g, o.detection.u, o.detection.v, 8, "#4f4");
    drawn += 1;
  }
  for (const t of o.tracks) {
    const target = t.id === o.target_id;
    g.lineWidth = target ? 3 : 1.5;
    circle(g, t.u, t.v, target ? 14 : 10, target ? "#f44" : t.confirmed ? "#fff" : "#aaa");
    g.fillStyle = target ? "#f44" : "#fff";
    g.fillText(`${target ? "target " : ""}${t.id}`, t.u + 16, t.v - 10);
    g.lineWidth = 1.5;
    drawn += 1;
  }
  if (o.prediction) {
    cross(g, o.prediction.u, o.prediction.v, 7, "#f4f", true);
    drawn += 1;
  }
  const state = view.state;
  if (state && state.gaze) {
    g.fillStyle = "rgba(0,0,0,0.55)";
    g.fillRect(0, 0, canvas.width, 22);
    g.fillStyle = "#fff";
    g.fillText(`${state.gaze.state}: ${state.gaze.reason}`, 6, 16);
  }
  view.overlaysDrawn = drawn;
  canvas.dataset.frames = String(view.framesShown + 1);
  canvas.dataset.overlays = String(drawn);
}

function circle(g, x, y, r, colour) {
  g.strokeStyle = colour;
  g.beginPath();
  g.arc(x, y, r, 0, 2 * Math.PI);
  g.stroke();
}

function cross(g, x, y, r, colour, diagonal = false) {
  g.strokeStyle = colour;
  g.beginPath();
  if (diagonal) {
    g.moveTo(x - r, y - r); g.lineTo(x + r, y + r); g.moveTo(x - r, y + r); g.lineTo(x + r, y - r);
  } else {
    g.moveTo(x - r, y); g.lineTo(x + r, y); g.moveTo(x, y - r); g.lineTo(x, y + r);
  }
  g.stroke();
}

$("frame").addEventListener("click", (event) => {
  if (!view.frame || !view.socket || view.socket.readyState !== WebSocket.OPEN) return;
  const canvas = event.currentTarget;
  const box = canvas.getBoundingClientRect();
  const u = ((event.clientX - box.left) / box.width) * canvas.width;
  const v = ((event.clientY - box.top) / box.height) * canvas.height;
  view.socket.send(JSON.stringify({ type: "select", seq: view.frame.meta.seq, u, v }));
});

$("rule").addEventListener("click", () => send({ type: "select" }));

for (const button of document.querySelectorAll("button[data-command]")) {
  button.addEventListener("click", () => send({ type: "command", command: button.dataset.command }));
}

function send(message) {
  if (view.socket && view.socket.readyState === WebSocket.OPEN) view.socket.send(JSON.stringify(message));
  else $("commanded").textContent = "not connected";
}

// -- the ground map -----------------------------------------------------------------------

// Where a track is predicted to be over the chosen target's prediction horizon (1 s without
// one), at its present velocity.
function predicted(track, state) {
  if (!track.velocity) return null;
  const horizon = state.prediction ? Math.max(state.prediction.horizon_s, 0) : 1.0;
  return [track.xy[0] + track.velocity[0] * horizon, track.xy[1] + track.velocity[1] * horizon];
}

function drawMap(state) {
  const canvas = $("map");
  const g = canvas.getContext("2d");
  g.fillStyle = "#000";
  g.fillRect(0, 0, canvas.width, canvas.height);
  const drawn = { tracks: 0, predictions: 0, ellipses: 0 };
  view.mapDrawn = drawn;
  const points = [];
  for (const trail of view.trails.values()) points.push(...trail); // the predictions may run off
  if (state.prediction) points.push(state.prediction.xy);
  if (!points.length) return;
  const xs = points.map((p) => p[0]);
  const ys = points.map((p) => p[1]);
  const pad = 1.0;
  const x0 = Math.min(...xs) - pad, x1 = Math.max(...xs) + pad;
  const y0 = Math.min(...ys) - pad, y1 = Math.max(...ys) + pad;
  const scale = Math.min(canvas.width / (x1 - x0), canvas.height / (y1 - y0));
  const px = (p) => [(p[0] - x0) * scale, canvas.height - (p[1] - y0) * scale];
  g.strokeStyle = "#222";
  g.lineWidth = 1;
  for (let x = Math.ceil(x0); x <= x1; x += 1) line(g, px([x, y0]), px([x, y1]));
  for (let y = Math.ceil(y0); y <= y1; y += 1) line(g, px([x0, y]), px([x1, y]));
  g.font = "12px system-ui, sans-serif";
  for (const track of state.tracks) {
    const target = track.id === state.target_id;
    const colour = target ? "#f44" : "#ddd";
    const trail = view.trails.get(track.id) || [];
    g.strokeStyle = colour;
    g.globalAlpha = 0.5;
    g.beginPath();
    trail.forEach((p, i) => (i ? g.lineTo(...px(p)) : g.moveTo(...px(p))));
    g.stroke();
    g.globalAlpha = 1;
    if (track.cov) {
      ellipse(g, px, track.xy, track.cov, scale, colour);
      drawn.ellipses += 1;
    }
    const ahead = predicted(track, state);
    if (ahead) {
      g.setLineDash([3, 3]);
      line(g, px(track.xy), px(ahead));
      g.setLineDash([]);
      drawn.predictions += 1;
    }
    const [u, v] = px(track.xy);
    g.fillStyle = colour;
    g.beginPath();
    g.arc(u, v, 4, 0, 2 * Math.PI);
    g.fill();
    g.fillText(String(track.id), u + 6, v - 6);
    drawn.tracks += 1;
  }
  if (state.prediction) {
    const [u, v] = px(state.prediction.xy);
    cross(g, u, v, 6, "#f4f", true);
    drawn.predictions += 1;
    if (state.prediction.cov) {
      ellipse(g, px, state.prediction.xy, state.prediction.cov, scale, "#f4f");
      drawn.ellipses += 1;
    }
  }
}

function line(g, a, b) {
  g.beginPath();
  g.moveTo(...a);
  g.lineTo(...b);
  g.stroke();
}

// The 2-sigma ellipse of a 2x2 covariance (m^2) around a ground point.
function ellipse(g, px, xy, cov, scale, colour) {
  const a = cov[0][0], b = cov[0][1], d = cov[1][1];
  const mean = (a + d) / 2;
  const spread = Math.sqrt(((a - d) / 2) ** 2 + b * b);
  const major = Math.sqrt(Math.max(mean + spread, 0)), minor = Math.sqrt(Math.max(mean - spread, 0));
  const angle = 0.5 * Math.atan2(2 * b, a - d);
  const [u, v] = px(xy);
  g.strokeStyle = colour;
  g.beginPath();
  g.ellipse(u, v, 2 * major * scale, 2 * minor * scale, -angle, 0, 2 * Math.PI);
  g.stroke();
}

// -- the plots ------------------------------------------------------------------------------

function plot(canvas, series, ymin, ymax) {
  const g = canvas.getContext("2d");
  g.fillStyle = "#000";
  g.fillRect(0, 0, canvas.width, canvas.height);
  if (!series.length) return;
  const names = [...new Set(series.flatMap((s) => Object.keys(s.values)))];
  const top = ymax ?? Math.max(1, ...series.flatMap((s) => Object.values(s.values))) * 1.1;
  const t1 = series[series.length - 1].t, t0 = t1 - HISTORY_S;
  const left = 36, right = 110, h = canvas.height - 16;
  const x = (t) => left + ((t - t0) / HISTORY_S) * (canvas.width - left - right);
  const y = (value) => 4 + (1 - (value - ymin) / (top - ymin)) * (h - 4);
  g.font = "11px system-ui, sans-serif";
  g.fillStyle = "#889";
  g.fillText(top.toFixed(top < 10 ? 1 : 0), 2, 12);
  g.fillText(String(ymin), 2, h);
  g.fillText(`last ${HISTORY_S} s`, left, canvas.height - 2);
  names.forEach((name, i) => {
    const colour = COLOURS[i % COLOURS.length];
    g.strokeStyle = colour;
    g.lineWidth = 1.5;
    g.beginPath();
    let started = false;
    for (const s of series) {
      if (!(name in s.values)) continue;
      const point = [x(s.t), y(s.values[name])];
      if (started) g.lineTo(...point);
      else g.moveTo(...point);
      started = true;
    }
    g.stroke();
    g.fillStyle = colour;
    const last = series[series.length - 1].values[name];
    const label = last === undefined ? name : `${name} ${last.toFixed(last < 10 ? 2 : 0)}`;
    g.fillText(label, canvas.width - right + 6, 12 + i * 13);
  });
}

connect();
