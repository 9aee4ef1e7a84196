// The ground page: a Foxglove WebSocket protocol client (subprotocol foxglove.websocket.v1)
// for the ground link of the same host. No build step, no external resources: the plots are
// uPlot's (vendor/, served by the link like this file).
"use strict";

const DEG = 180 / Math.PI;
const RPM = 60 / (2 * Math.PI);
const WINDOW_S = 60;            // plot window, simulated s
const STALE_AFTER_S = 1.0;      // no message for this long: the link is stale
const HEARTBEAT_STALE_S = 2.0;  // a process's heartbeats (every 0.5 s) stopped this long: stale
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

// ---- series and plots (uPlot, vendor/uPlot.iife.min.js) ----
function push(name, t, v) {
  let s = state.series.get(name);
  if (!s) { s = { t: [], v: [] }; state.series.set(name, s); }
  s.t.push(t); s.v.push(Number.isFinite(v) ? v : null);   // a value JSON could not carry: a gap
  let old = 0;
  while (old < s.t.length && s.t[old] < t - WINDOW_S) old++;
  if (old) { s.t.splice(0, old); s.v.splice(0, old); }
  state.dirty = true;
}
const AXES = { hpr: ["heading", "tilt x θ", "tilt y φ"], xyz: ["x", "y", "z"], wheels: ["X", "Y", "Z"], cmgs: ["1", "2", "3", "4"] };
// One plot per element: its unit (axis label and legend values) and its lines, each a series
// key of `push`, a legend label and a colour; dashed lines are a second source of the same axes.
const PLOTS = [
  ["plot-attitude", "deg", 220, [...lines("est", AXES.hpr, "estimate"), ...lines("tgt", AXES.hpr, "target", [6, 4]), ...lines("tru", AXES.hpr, "truth", [2, 3])]],
  ["plot-error", "deg", 180, [...lines("err", AXES.xyz, "error"), ...lines("sig+", AXES.xyz, "+3σ", [4, 3]), ...lines("sig-", AXES.xyz, "−3σ", [4, 3])]],
  ["plot-rate", "deg/s", 180, lines("rate", AXES.xyz, "rate")],
  ["plot-wheel-speed", "rpm", 160, lines("wspd", AXES.wheels, "wheel")],
  ["plot-wheel-torque", "mN m", 160, lines("wtrq", AXES.wheels, "wheel")],
  ["plot-gimbal", "deg", 140, lines("gim", AXES.cmgs, "gimbal")],
  ["plot-gimbal-rate", "deg/s", 140, lines("grate", AXES.cmgs, "gimbal")],
  ["plot-thrust", "ms", 160, lines("thr", AXES.xyz, "axis")],
].map(([id, unit, height, series]) => ({ id, unit, height, series, chart: null }));
function lines(prefix, names, what, dash) {
  return names.map((n, i) => ({ key: `${prefix}${i}`, label: `${what} ${n}`, color: COLORS[i], dash }));
}
function format(v, unit) { return v == null ? "–" : `${Number(v.toPrecision(4))} ${unit}`; }
function makeChart(p) {
  const el = $(p.id);
  const opts = {
    width: Math.max(300, el.clientWidth), height: p.height,
    scales: { x: { time: false, range: () => [Math.max(0, state.simTime - WINDOW_S), Math.max(state.simTime, 1)] } },
    axes: [{ label: "run time, s", labelSize: 18, size: 36 }, { label: p.unit, labelSize: 18, size: 64 }],
    series: [
      { label: "t", value: (u, v) => format(v, "s") },
      ...p.series.map((l) => ({ label: l.label, stroke: l.color, dash: l.dash, width: 1.4, spanGaps: false, value: (u, v) => format(v, p.unit) })),
    ],
    cursor: { drag: { x: false, y: false } },
  };
  p.chart = new uPlot(opts, [[], ...p.series.map(() => [])], el);
}
// The lines of a plot on one time axis: each source's samples where it has them, gaps elsewhere.
function plotData(p) {
  const tables = p.series.map((l) => { const s = state.series.get(l.key); return s ? [s.t, s.v] : [[], []]; });
  return uPlot.join(tables);
}
function redraw() {
  if (!state.dirty) return;
  state.dirty = false;
  for (const p of PLOTS) {
    if (p.id === "plot-thrust" && !state.thrusters) continue;
    if (!p.chart) makeChart(p);
    p.chart.setData(plotData(p));
  }
}
window.addEventListener("resize", () => {
  for (const p of PLOTS) if (p.chart) p.chart.setSize({ width: Math.max(300, $(p.id).clientWidth), height: p.height });
});

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
  const now = performance.now(), live = linkLive();
  const rows = [...state.processes.entries()].sort(([a], [b]) => a.localeCompare(b)).map(([name, { hb, at }]) => {
    const st = STATES[hb.state] || hb.state;
    const misses = name === "controller" ? state.deadlineMisses : "";
    // A row says what the process last said; once its heartbeats stop (or the link is gone) that
    // is no longer known, and the row says so.
    const age = (now - at) / 1000;
    const stale = !live || age > HEARTBEAT_STALE_S;
    const shown = stale ? `${st}? (${live ? `no heartbeat for ${age.toFixed(1)} s` : "link lost"})` : st;
    return `<tr class="state-${st}${stale ? " stale" : ""}" data-name="${name}" data-stale="${stale}"><td>${name}</td><td>${shown}</td><td>${age.toFixed(1)}</td>` +
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

function linkLive() {
  const open = state.ws && state.ws.readyState === WebSocket.OPEN;
  return open && (performance.now() - state.lastMessage) / 1000 < STALE_AFTER_S;
}
function showLink() {
  const e = $("link"), open = state.ws && state.ws.readyState === WebSocket.OPEN;
  const age = (performance.now() - state.lastMessage) / 1000;
  if (linkLive()) {
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
