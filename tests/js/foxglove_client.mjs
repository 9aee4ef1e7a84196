// Foxglove's own WebSocket protocol client (@foxglove/ws-protocol's FoxgloveClient, over the
// `ws` package) against a running ground link: the conformance check of the link, run by
// tests/tests/ground.rs. Prints one JSON summary line on stdout; exits 1 naming the first
// failed check.
//
//   node foxglove_client.mjs --url ws://127.0.0.1:8765/ --token T [--ca cert.pem]
//        [--old-token T0] [--seconds 6]
//
// Checked: the server info (capabilities, encodings, the role of the connection); every
// subscribed channel's messages against the JSON Schema it advertised, and the `foxglove.*`
// ones against @foxglove/schemas too; a mode command advertised and published the standard
// way (`advertise`, client message data) and answered by the controller (acknowledgement and
// controller status); a wrong token in a command refused with its reason; the run
// configuration as read-only parameters; `time` messages; a connection without a token
// watches (no clientPublish, its advertise and its command refused); a wrong or earlier run's
// token on the URL refused at the handshake with its reason.

import { createRequire } from "node:module";
import { readFileSync } from "node:fs";

// The packages are CommonJS: required as they document it.
const require = createRequire(import.meta.url);
const { FoxgloveClient } = require("@foxglove/ws-protocol");
const WebSocket = require("ws");
const Ajv = require("ajv").default;
const Ajv2020 = require("ajv/dist/2020").default;
const foxgloveSchemas = require("@foxglove/schemas/jsonschema");

const args = Object.fromEntries(
  process.argv.slice(2).reduce((pairs, a, i, all) => {
    if (a.startsWith("--")) pairs.push([a.slice(2), all[i + 1]]);
    return pairs;
  }, []),
);
const base = args.url;
const token = args.token;
const seconds = Number(args.seconds ?? 6);
const tlsOptions = args.ca ? { ca: readFileSync(args.ca) } : {};
if (!base || !token) {
  console.error("usage: foxglove_client.mjs --url URL --token TOKEN [--ca FILE] [--old-token T] [--seconds S]");
  process.exit(2);
}

const failures = [];
function check(ok, what) {
  if (!ok) failures.push(what);
  return ok;
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
async function until(what, ms, f) {
  const start = Date.now();
  for (;;) {
    const v = f();
    if (v) return v;
    if (Date.now() - start > ms) throw new Error(`timed out waiting for ${what}`);
    await sleep(50);
  }
}

// A JSON Schema validator for a schema text: draft 2020-12 if it says so, else draft-07.
function compile(schemaText) {
  const schema = typeof schemaText === "string" ? JSON.parse(schemaText) : schemaText;
  const is2020 = typeof schema.$schema === "string" && schema.$schema.includes("2020-12");
  const ajv = is2020 ? new Ajv2020({ strict: true, allowUnionTypes: true, allErrors: true }) : new Ajv({ strict: true, allowUnionTypes: true, allErrors: true });
  return ajv.compile(schema);
}

function url(query) {
  return base + (base.endsWith("/") ? "" : "/") + query;
}

// A FoxgloveClient on `query`; resolves with the client and what it saw so far.
function connect(query) {
  const ws = new WebSocket(url(query), [FoxgloveClient.SUPPORTED_SUBPROTOCOL], tlsOptions);
  const seen = { info: null, channels: [], statuses: [], times: [], messages: [], params: [], closed: null, error: null };
  const refused = new Promise((resolve) => {
    ws.on("unexpected-response", (_req, res) => {
      let body = "";
      res.on("data", (d) => (body += d));
      res.on("end", () => resolve({ status: res.statusCode, body }));
    });
  });
  const client = new FoxgloveClient({ ws });
  client.on("serverInfo", (m) => (seen.info = m));
  client.on("advertise", (chs) => seen.channels.push(...chs));
  client.on("status", (m) => seen.statuses.push(m));
  client.on("time", (m) => seen.times.push(m.timestamp));
  client.on("message", (m) => seen.messages.push(m));
  client.on("parameterValues", (m) => seen.params.push(m));
  client.on("close", (e) => (seen.closed = { code: e.code, reason: String(e.reason ?? "") }));
  client.on("error", (e) => (seen.error = String(e && e.message)));
  return { ws, client, seen, refused };
}

const decoder = new TextDecoder();
const encoder = new TextEncoder();
const json = (dataView) => JSON.parse(decoder.decode(dataView));

const summary = { channels: {}, foxglove_validated: 0, validated: 0 };

try {
  // --- The commanding connection: everything subscribed, every message validated. ---
  const cmd = connect(`?token=${encodeURIComponent(token)}`);
  await until("serverInfo and advertise", 15000, () => cmd.seen.info && cmd.seen.channels.length > 0);
  const info = cmd.seen.info;
  check(info.capabilities.includes("clientPublish"), "commanding connection: clientPublish declared");
  check(info.capabilities.includes("parameters"), "parameters declared");
  check(info.capabilities.includes("time"), "time declared");
  check(JSON.stringify(info.supportedEncodings) === '["json"]', `supportedEncodings ${JSON.stringify(info.supportedEncodings)}`);
  check(info.metadata.role === "command", `role ${info.metadata.role}`);
  const startNs = BigInt(info.metadata.start_time_ns);

  const bySub = new Map();
  const subscriptions = [];
  for (const ch of cmd.seen.channels) {
    check(ch.encoding === "json" && ch.schemaEncoding === "jsonschema", `${ch.topic}: json with jsonschema`);
    const validators = [["own", compile(ch.schema)]];
    if (ch.schemaName.startsWith("foxglove.")) {
      const name = ch.schemaName.slice("foxglove.".length);
      const official = foxgloveSchemas[name];
      if (check(official, `@foxglove/schemas has ${ch.schemaName}`)) validators.push(["foxglove", compile(official)]);
    }
    const sub = cmd.client.subscribe(ch.id);
    bySub.set(sub, { ch, validators });
    subscriptions.push(sub);
    summary.channels[ch.topic] = 0;
  }

  // A mode command, the standard way: advertise a client channel, publish JSON on it.
  const commandChannel = cmd.client.advertise({
    topic: "testbed/ground/command",
    encoding: "json",
    schemaName: "testbed::ground::CommandRequest",
  });
  await sleep(300);
  cmd.client.sendMessage(commandChannel, encoder.encode(JSON.stringify({ id: 1, command: "mode", mode: "rate_damping" })));
  const sent = await until("the link's status for command 1", 10000, () => cmd.seen.statuses.find((s) => s.id === "cmd-1"));
  check(sent.level === 0, `command 1: ${sent.message}`);

  // A wrong token in the payload: refused with its reason (after the rate limit's burst).
  cmd.client.sendMessage(commandChannel, encoder.encode(JSON.stringify({ token: "not-the-token-0123", id: 2, command: "mode", mode: "idle" })));
  const wrong = await until("the status for command 2", 10000, () => cmd.seen.statuses.find((s) => s.id === "cmd-2"));
  check(wrong.level === 2 && wrong.message === "command 2 rejected: wrong token", `command 2: ${wrong.message}`);

  // An advertised channel of another encoding, or another topic: refused, said why.
  cmd.client.advertise({ topic: "testbed/ground/command", encoding: "protobuf", schemaName: "x" });
  cmd.client.advertise({ topic: "somewhere/else", encoding: "json", schemaName: "x" });

  // Parameters: the run configuration, read-only, the token left out.
  cmd.client.getParameters([], "all");
  cmd.client.setParameters([{ name: "ground.max_target_tilt_deg", value: 80 }], "set");

  const deadline = Date.now() + seconds * 1000;
  while (Date.now() < deadline) await sleep(100);

  for (const m of cmd.seen.messages) {
    const entry = bySub.get(m.subscriptionId);
    if (!check(entry, `message of an unknown subscription ${m.subscriptionId}`)) continue;
    const value = json(m.data);
    summary.channels[entry.ch.topic] += 1;
    check(m.timestamp >= startNs, `${entry.ch.topic}: message time before the run's start`);
    for (const [which, validate] of entry.validators) {
      if (validate(value)) {
        if (which === "foxglove") summary.foxglove_validated += 1;
        else summary.validated += 1;
      } else {
        check(false, `${entry.ch.topic} (${which} schema ${entry.ch.schemaName}): ${JSON.stringify(validate.errors.slice(0, 3))} in ${JSON.stringify(value).slice(0, 300)}`);
      }
    }
  }
  const topicOf = (m) => bySub.get(m.subscriptionId)?.ch.topic;
  const acks = cmd.seen.messages.filter((m) => topicOf(m) === "testbed/ground/command_ack").map((m) => json(m.data));
  const applied = acks.find((a) => a.command_id === 1);
  check(applied && applied.status === 1 && applied.reason === "mode RateDamping", `ack of command 1: ${JSON.stringify(applied)}`);
  const refusedAck = acks.find((a) => a.command_id === 2);
  check(refusedAck && refusedAck.status === 2 && refusedAck.reason === "wrong token", `ack of command 2: ${JSON.stringify(refusedAck)}`);
  const modes = cmd.seen.messages.filter((m) => topicOf(m) === "testbed/gnc/controller_status").map((m) => json(m.data).mode);
  check(modes.length > 0 && modes[modes.length - 1] === 1, `controller modes seen ${JSON.stringify(modes.slice(-5))}, want RateDamping (1) last`);
  summary.modes_seen = [...new Set(modes)];
  for (const topic of ["testbed/gnc/attitude_estimate", "testbed/tf/estimate", "testbed/pose/estimate", "testbed/scene", "testbed/events", "testbed/ground/link"]) {
    check(summary.channels[topic] > 0, `no message on ${topic}`);
  }
  check(summary.foxglove_validated > 0, "no foxglove.* message validated");
  // The link's stamped-to-sent latency (a paced run): reported, and plausible.
  const links = cmd.seen.messages.filter((m) => topicOf(m) === "testbed/ground/link").map((m) => json(m.data));
  const latency = links.at(-1)?.latency_ms;
  check(
    latency && typeof latency.mean === "number" && latency.mean >= 0 && latency.mean < 1000 && latency.max >= latency.mean,
    `latency_ms on testbed/ground/link: ${JSON.stringify(latency)}`,
  );
  summary.latency_ms = latency;

  const refusals = cmd.seen.statuses.filter((s) => s.message.startsWith("client channel")).map((s) => s.message);
  check(refusals.some((m) => m.includes('encoding "protobuf" not supported')), `protobuf channel: ${JSON.stringify(refusals)}`);
  check(refusals.some((m) => m.includes("commands on testbed/ground/command only")), `other topic: ${JSON.stringify(refusals)}`);
  const all = cmd.seen.params.find((p) => p.id === "all");
  if (check(all, "parameterValues for getParameters")) {
    const names = all.parameters.map((p) => p.name);
    check(names.includes("ground.max_target_tilt_deg") && names.includes("run.seed"), `parameters ${names.slice(0, 8)}`);
    check(!names.some((n) => n.includes("token")), "the command token is not a parameter");
    summary.parameters = names.length;
  }
  const set = cmd.seen.statuses.find((s) => s.message.startsWith("parameters are read-only"));
  check(set && set.level === 2, "setParameters refused as read-only");
  const setValues = cmd.seen.params.find((p) => p.id === "set");
  check(setValues && setValues.parameters[0]?.value === 20, `setParameters answered with the unchanged value: ${JSON.stringify(setValues)}`);
  check(cmd.seen.times.length > 0 && cmd.seen.times.at(-1) >= startNs, `time messages: ${cmd.seen.times.length}`);
  summary.times = cmd.seen.times.length;

  // --- A connection without a token watches. ---
  const watch = connect("");
  await until("the watcher's serverInfo", 10000, () => watch.seen.info && watch.seen.channels.length > 0);
  check(!watch.seen.info.capabilities.includes("clientPublish"), "watcher: no clientPublish");
  check(watch.seen.info.supportedEncodings === undefined, "watcher: no supportedEncodings");
  check(watch.seen.info.metadata.role === "watch", `watcher role ${watch.seen.info.metadata.role}`);
  const estimate = watch.seen.channels.find((c) => c.topic === "testbed/gnc/attitude_estimate");
  watch.client.subscribe(estimate.id);
  const watchChannel = watch.client.advertise({ topic: "testbed/ground/command", encoding: "json", schemaName: "" });
  await sleep(200);
  watch.client.sendMessage(watchChannel, encoder.encode(JSON.stringify({ token, id: 3, command: "mode", mode: "idle" })));
  const watchRefused = await until("the watcher's command refused", 10000, () => watch.seen.statuses.find((s) => s.id === "cmd-3"));
  check(watchRefused.level === 2 && watchRefused.message.includes("watch-only connection"), `watcher's command: ${watchRefused.message}`);
  check(watch.seen.statuses.some((s) => s.message.startsWith("advertise refused: watch-only")), "watcher's advertise refused");
  await until("a message for the watcher", 10000, () => watch.seen.messages.length > 0);
  summary.watcher_messages = watch.seen.messages.length;
  watch.client.close();

  // --- A wrong token, and an earlier run's, refused at the handshake with the reason. ---
  for (const [what, bad] of [["wrong", "guess-guess-guess-guess"], ["old", args["old-token"]]]) {
    if (!bad) continue;
    const c = connect(`?token=${encodeURIComponent(bad)}`);
    const r = await Promise.race([c.refused, sleep(10000).then(() => null)]);
    check(r && r.status === 401 && r.body.startsWith("wrong command token"), `${what} token: ${JSON.stringify(r)}`);
    summary[`${what}_token_refused`] = r && r.status;
  }

  cmd.client.close();
} catch (e) {
  failures.push(String(e && e.stack ? e.stack : e));
}

summary.failures = failures;
console.log(JSON.stringify(summary));
process.exit(failures.length === 0 ? 0 : 1);
