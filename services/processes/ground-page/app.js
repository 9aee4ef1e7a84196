// The ground page: a Foxglove WebSocket protocol client (subprotocol foxglove.websocket.v1)
// for the ground link of the same host. No build step, no external resources.
"use strict";

const DEG = 180 / Math.PI;
const RPM = 60 / (2 * Math.PI);
const WINDOW_S = 60;            // plot window, simulated s
const STALE_AFTER_S = 1.0;      // no message for this long: the link is stale
const MODES = ["Idle", "RateDamping", "WheelPointing", "CmgSlew", "Fault", "Safe", "MomentumDump", "ThrusterRateDamping"];
const STATES = ["Starting", "Running", "Degraded", "Stopping", "Faulted"];
const COMMAND_KINDS = ["unknown", "mode", "target", "experiment start", "experiment abort"];
const CAN_NAMES = { 1: "CAN node", 2: "gyro gw", 3: "inclinometer gw", 4: "magnetometer gw", 5: "wheel gw", 6: "CMG gw", 8: "thruster gw" };
const COLORS = ["#d32f2f", "#388e3c", "#1976d2", "#f57c00"];
const COMMAND_CHANNEL = 1;

const $ = (id) => document.getElementById(id);
const state = {
  ws: null, channels: new Map(), viewerId: null, lastMessage: 0, openedAt: 0,
  retryMs: 500, nextCommandId: 1, series: new Map(), processes: new Map(),
  restarts: new Map(), can: new Map(), deadlineMisses: 0, simTime: 0, startNs: 0n, target: null, dirty: false,
  thrusters: false,
};

// ---- attitude helpers (conventions of ipc-types: q = [x, y, z, w], L→B) ----
function rotate(q, v) {           // components of v (level frame) in the body frame: q v q*
  const [x, y, z, w] = q;
  const tx = 2 * (y * v[2] - z * v[1]), ty = 2 * (z * v[0] - x * v[2]), tz = 2 * (x * v[1] - y * v[0]);
  return [v[0] + w * tx + (y * tz - z * ty), v[1] + w * ty + (z * tx - x * tz), v[2] + w * tz + (x * ty - y * tx)];
}
function conj(q) { return [-q[0], -q[1], -q[2], q[3]]; }
function clampAsin(x) { return Math.asin(Math.max(-1, Math.min(1, x))); }
function headingTilt(q) {         // heading, tilt θ (body x), tilt φ (body y), deg
  const g = rotate(q, [0, 0, -1]);
  const xl = rotate(conj(q), [1, 0, 0]);
  return [Math.atan2(xl[1], xl[0]) * DEG, clampAsin(g[0]) * DEG, clampAsin(g[1]) * DEG];
}

// ---- series and plots ----
function push(name, t, v) {
  let s = state.series.get(name);
  if (!s) { s = []; state.series.set(name, s); }
  s.push([t, v]);
  while (s.length && s[0][0] < t - WINDOW_S) s.shift();
  state.dirty = true;
}
function plot(canvasId, lines) {
  const c = $(canvasId), g = c.getContext("2d"), W = c.width, H = c.height, L = 46, B = 14;
  g.clearRect(0, 0, W, H);
  const t1 = state.simTime, t0 = t1 - WINDOW_S;
  let lo = Infinity, hi = -Infinity;
  for (const l of lines) for (const [t, v] of state.series.get(l.name) || []) {
    if (t >= t0 && Number.isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
  }
  if (!Number.isFinite(lo)) { g.fillStyle = "#99a"; g.fillText("no data", W / 2 - 20, H / 2); return; }
  if (hi - lo < 1e-9) { hi += 1e-3; lo -= 1e-3; }
  const pad = (hi - lo) * 0.08; lo -= pad; hi += pad;
  const X = (t) => L + (t - t0) / WINDOW_S * (W - L - 4), Y = (v) => 4 + (hi - v) / (hi - lo) * (H - B - 8);
  g.strokeStyle = "#e3e5ea"; g.fillStyle = "#667"; g.font = "11px sans-serif";
  for (let i = 0; i <= 4; i++) {
    const v = lo + (hi - lo) * i / 4, y = Y(v);
    g.beginPath(); g.moveTo(L, y); g.lineTo(W, y); g.stroke();
    g.fillText(v.toPrecision(3), 2, y + 4);
  }
  g.fillText(`${t0.toFixed(0)} s`, L, H - 2); g.fillText(`${t1.toFixed(1)} s`, W - 50, H - 2);
  for (const l of lines) {
    const data = state.series.get(l.name) || [];
    g.strokeStyle = l.color; g.setLineDash(l.dash || []); g.lineWidth = 1.4; g.beginPath();
    let first = true;
    for (const [t, v] of data) {
      if (t < t0 || !Number.isFinite(v)) continue;
      if (first) { g.moveTo(X(t), Y(v)); first = false; } else g.lineTo(X(t), Y(v));
    }
    g.stroke();
  }
  g.setLineDash([]);
}
function axes(prefix, n, dash) {
  return Array.from({ length: n }, (_, i) => ({ name: `${prefix}${i}`, color: COLORS[i], dash }));
}
function redraw() {
  if (!state.dirty) return;
  state.dirty = false;
  plot("plot-attitude", [...axes("est", 3), ...axes("tgt", 3, [6, 4]), ...axes("tru", 3, [2, 3])]);
  plot("plot-error", [...axes("err", 3), ...axes("sig+", 3, [4, 3]), ...axes("sig-", 3, [4, 3])]);
  plot("plot-rate", axes("rate", 3));
  plot("plot-wheel-speed", axes("wspd", 3));
  plot("plot-wheel-torque", axes("wtrq", 3));
  plot("plot-gimbal", axes("gim", 4));
  plot("plot-gimbal-rate", axes("grate", 4));
  if (state.thrusters) plot("plot-thrust", axes("thr", 3));
}

// ---- displays ----
function setNumber(id, value, digits) {
  const e = $(id);
  e.textContent = Number.isFinite(value) ? value.toFixed(digits) : "–";
  e.dataset.value = String(value);
}
function setVector(id, values, digits) {
  const e = $(id);
  e.textContent = "[" + values.map((v) => v.toFixed(digits)).join(", ") + "]";
  e.dataset.value = JSON.stringify(values);
}
function event(text, cls) {
  const li = document.createElement("li");
  li.textContent = `t = ${state.simTime.toFixed(1)} s  ${text}`;
  if (cls) li.className = cls;
  const list = $("events");
  list.prepend(li);
  while (list.children.length > 200) list.lastChild.remove();
}
function commandResult(text, cls) {
  const e = $("cmd-result");
  e.textContent = text; e.className = cls; e.dataset.value = text;
}

const handlers = {
  "testbed/gnc/attitude_estimate"(m, t) {
    if (!(m.header.flags & 1)) return;
    const hpr = headingTilt(m.quaternion);
    hpr.forEach((v, i) => push(`est${i}`, t, v));
    setNumber("est-h", hpr[0], 3); setNumber("est-t", hpr[1], 3); setNumber("est-p", hpr[2], 3);
    setVector("est-q", m.quaternion, 6);
    $("est-time").textContent = String(m.header.time_ns); $("est-time").dataset.value = String(m.header.time_ns);
    m.rate.forEach((v, i) => push(`rate${i}`, t, v * DEG));
    setVector("rate-now", m.rate.map((v) => v * DEG), 4);
    for (let i = 0; i < 3; i++) {
      const s = 3 * Math.sqrt(Math.max(0, m.covariance[7 * i])) * DEG;
      push(`sig+${i}`, t, s); push(`sig-${i}`, t, -s);
    }
    if (state.target) state.target.forEach((v, i) => push(`tgt${i}`, t, v));
  },
  "testbed/sim/truth"(m, t) {
    const hpr = headingTilt(m.quaternion);
    hpr.forEach((v, i) => push(`tru${i}`, t, v));
    setNumber("tru-h", hpr[0], 3); setNumber("tru-t", hpr[1], 3); setNumber("tru-p", hpr[2], 3);
    setVector("tru-q", m.quaternion, 6);
    $("tru-time").textContent = String(m.header.time_ns);
  },
  "testbed/gnc/controller_status"(m, t) {
    m.attitude_error.forEach((v, i) => push(`err${i}`, t, v * DEG));
    setVector("error-now", m.attitude_error.map((v) => v * DEG), 4);
    const mode = $("mode");
    mode.textContent = MODES[m.mode] || `mode ${m.mode}`; mode.dataset.value = String(m.mode);
    state.deadlineMisses = m.deadline_misses;
  },
  "testbed/actuators/wheels/telemetry"(m, t) { m.speed.forEach((v, i) => push(`wspd${i}`, t, v * RPM)); },
  "testbed/actuators/wheels/command"(m, t) { m.torque.forEach((v, i) => push(`wtrq${i}`, t, v * 1000)); },
  "testbed/ground/cmg"(m, t) {
    m.gimbal_angle.forEach((v, i) => push(`gim${i}`, t, v * DEG));
    m.gimbal_rate.forEach((v, i) => push(`grate${i}`, t, v * DEG));
    setNumber("singularity", m.singularity_measure, 3);
  },
  // Valve on-time per axis, + thruster minus − thruster (thruster 2a: + torque about axis a).
  "testbed/actuators/thrusters/status"(m, t) {
    if (!state.thrusters) { state.thrusters = true; $("thrusters").style.display = ""; }
    for (let a = 0; a < 3; a++) push(`thr${a}`, t, (m.applied_on_time[2 * a] - m.applied_on_time[2 * a + 1]) * 1000);
    const open = [0, 1, 2, 3, 4, 5].filter((i) => m.valves_open & (1 << i)).join(" ") || "none";
    const e = $("thr-info");
    e.textContent = `propellant used ${(m.propellant_used * 1000).toFixed(2)} g · refused ${m.refused} · valves open: ${open}` +
      (m.disabled ? " · DISABLED (latch valve shut)" : "");
    e.className = m.disabled ? "rejected" : "";
    e.dataset.value = String(m.propellant_used);
  },
  "testbed/system/heartbeat"(m) {
    state.processes.set(m.name, { hb: m, at: performance.now() });
  },
  "testbed/system/health"(m) {
    if (m.kind === 5) state.restarts.set(m.subject, m.detail);
  },
  "testbed/can/status"(m) { state.can.set(m.header.source_id, m); },
  "testbed/ground/command"(m) {
    event(`ground command ${m.command_id} (${COMMAND_KINDS[m.kind] || m.kind}) from viewer ${m.client_id} sent to the controller`);
  },
  "testbed/ground/command_ack"(m) {
    const applied = m.status === 1;
    const by = m.decided_by === 2 ? "controller" : "ground link";
    const text = `command ${m.command_id} ${applied ? "applied" : "rejected"} by the ${by}: ${m.reason}`;
    if (m.client_id === state.viewerId) commandResult(text, applied ? "ok" : "rejected");
  },
  // The run's events as foxglove.Log: health events, mode changes, acknowledgements.
  "testbed/events"(m) {
    const cls = m.level >= 4 ? "fault" : m.level === 3 ? "rejected" : /applied/.test(m.message) ? "applied" : "";
    event(`${m.name}: ${m.message}`, cls);
  },
  "testbed/ground/link"(m) {
    const d = m.target_deg;
    state.target = [d.heading, d.tilt_x, d.tilt_y];
    setNumber("tgt-h", d.heading, 3); setNumber("tgt-t", d.tilt_x, 3); setNumber("tgt-p", d.tilt_y, 3);
    $("linkstats").textContent = `viewers ${m.viewers} · sent ${m.sent} · dropped ${m.dropped} · bad messages ${m.bad_messages}`;
  },
};

function renderTables() {
  const now = performance.now();
  const rows = [...state.processes.entries()].sort(([a], [b]) => a.localeCompare(b)).map(([name, { hb, at }]) => {
    const st = STATES[hb.state] || hb.state;
    const misses = name === "controller" ? state.deadlineMisses : "";
    return `<tr class="state-${st}" data-name="${name}"><td>${name}</td><td>${st}</td><td>${((now - at) / 1000).toFixed(1)}</td>` +
      `<td>${hb.samples_in}</td><td>${hb.samples_out}</td><td>${hb.errors}</td><td>${hb.frames_ok} / ${hb.frames_bad}</td>` +
      `<td>${state.restarts.get(name) || 0}</td><td>${misses}</td></tr>`;
  });
  $("health").tBodies[0].innerHTML = rows.join("");
  const can = [...state.can.entries()].sort(([a], [b]) => a - b).map(([id, c]) =>
    `<tr><td>${CAN_NAMES[id] || id}</td><td>${c.frames_ok}</td><td>${c.frames_bad}</td><td>${c.crc_errors}</td>` +
    `<td>${c.lost_frames}</td><td>${c.late_frames}</td><td>${c.frames_sent}</td><td>${c.transport_errors}</td></tr>`);
  $("can").tBodies[0].innerHTML = can.join("");
  $("can").style.display = can.length ? "" : "none";
}

function showLink() {
  const e = $("link"), open = state.ws && state.ws.readyState === WebSocket.OPEN;
  const age = (performance.now() - state.lastMessage) / 1000;
  if (open && age < STALE_AFTER_S) {
    e.textContent = "live"; e.className = "badge ok"; e.dataset.state = "live";
  } else if (state.lastMessage) {
    e.textContent = `stale since ${age.toFixed(1)} s` + (open ? "" : " · reconnecting");
    e.className = "badge bad"; e.dataset.state = "stale";
  }
}

// ---- protocol ----
function onMessageData(buf) {
  const view = new DataView(buf);
  if (view.byteLength < 13 || view.getUint8(0) !== 1) return;
  const sub = view.getUint32(1, true);
  // Message times are the run's wall-clock start plus the run clock: plot the run clock.
  const timeNs = Number(view.getBigUint64(5, true) - state.startNs);
  const topic = state.channels.get(sub);
  const handler = topic && handlers[topic];
  if (!handler) return;
  let message;
  try { message = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 13))); } catch { return; }
  const t = timeNs / 1e9;
  if (topic !== "testbed/system/heartbeat" && t > state.simTime) {
    state.simTime = t; setNumber("simtime", t, 1);
  }
  handler(message, t);
}

function onText(text) {
  let m;
  try { m = JSON.parse(text); } catch { return; }
  if (m.op === "serverInfo") {
    state.viewerId = m.metadata && m.metadata.viewer_id;
    // A connection without the command token watches: the link declares no clientPublish.
    state.canPublish = (m.capabilities || []).includes("clientPublish");
    state.startNs = BigInt((m.metadata && m.metadata.start_time_ns) || "0");
  } else if (m.op === "advertise") {
    const subs = [];
    for (const c of m.channels) {
      state.channels.set(c.id, c.topic);
      if (handlers[c.topic]) subs.push({ id: c.id, channelId: c.id });
    }
    send(JSON.stringify({ op: "subscribe", subscriptions: subs }));
    if (state.canPublish) {
      send(JSON.stringify({ op: "advertise", channels: [{ id: COMMAND_CHANNEL, topic: "testbed/ground/command", encoding: "json", schemaName: "testbed::ground::CommandRequest" }] }));
    }
  } else if (m.op === "status" && typeof m.id === "string" && m.id.startsWith("cmd-")) {
    commandResult(m.message, m.level >= 2 ? "rejected" : "ok");
    if (m.level >= 2) event(m.message, "rejected");
  }
}

function send(data) { if (state.ws && state.ws.readyState === WebSocket.OPEN) state.ws.send(data); }

function connect() {
  // The token on the URL gives the connection the command role (without it, it watches).
  const token = $("token").value;
  const query = token ? `?token=${encodeURIComponent(token)}` : "";
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  const ws = new WebSocket(`${scheme}://${location.host}/${query}`, ["foxglove.websocket.v1"]);
  ws.binaryType = "arraybuffer";
  state.ws = ws;
  state.channels.clear();
  ws.onopen = () => { state.retryMs = 500; state.openedAt = performance.now(); };
  ws.onmessage = (e) => {
    state.lastMessage = performance.now();
    if (typeof e.data === "string") onText(e.data); else onMessageData(e.data);
  };
  ws.onclose = () => {
    if (state.ws !== ws) return;
    setTimeout(connect, state.retryMs);
    state.retryMs = Math.min(5000, state.retryMs * 2);
  };
}

function command(body) {
  const id = state.nextCommandId++;
  const payload = new TextEncoder().encode(JSON.stringify({ token: $("token").value, id, ...body }));
  const frame = new Uint8Array(5 + payload.length);
  frame[0] = 1;
  new DataView(frame.buffer).setUint32(1, COMMAND_CHANNEL, true);
  frame.set(payload, 5);
  if (!state.ws || state.ws.readyState !== WebSocket.OPEN) { commandResult("not connected", "rejected"); return; }
  if (!state.canPublish) { commandResult("rejected: watching only (open the page with #token=<the run's command token>)", "rejected"); return; }
  commandResult(`command ${id} sent…`, "");
  state.ws.send(frame);
}

$("send-mode").onclick = () => command({ command: "mode", mode: $("cmd-mode").value });
$("send-target").onclick = () => command({
  command: "target", heading_deg: Number($("cmd-heading").value),
  pitch_deg: Number($("cmd-pitch").value), roll_deg: Number($("cmd-roll").value),
});
$("exp-start").onclick = () => command({ command: "experiment", action: "start" });
$("exp-abort").onclick = () => command({ command: "experiment", action: "abort" });
const fromHash = new URLSearchParams(location.hash.slice(1)).get("token");
if (fromHash) $("token").value = fromHash;

setInterval(() => { showLink(); renderTables(); redraw(); }, 250);
connect();
