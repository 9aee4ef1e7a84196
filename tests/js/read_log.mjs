// Reads a run log with @mcap/core's McapIndexedReader, as Foxglove does: opens it through the
// summary (chunk index), lists every channel and reads the messages of a time window.
// Usage: node tests/js/read_log.mjs LOG WINDOW_START_S WINDOW_LENGTH_S
// Prints one JSON object: channels (id → topic, message encoding, schema name), the chunk
// count and compressions, and for the window (seconds after the first message) the messages
// read per topic, the first and last log time read (ns, as strings: beyond 2^53) and whether
// they come in log-time order.
import { open } from "node:fs/promises";
import { McapIndexedReader } from "@mcap/core";
import { decompress } from "fzstd";

const [path, startArg, lengthArg] = process.argv.slice(2);
const handle = await open(path, "r");
const readable = {
  size: async () => BigInt((await handle.stat()).size),
  read: async (offset, length) => {
    const buffer = new Uint8Array(Number(length));
    await handle.read(buffer, 0, buffer.length, Number(offset));
    return buffer;
  },
};
const reader = await McapIndexedReader.Initialize({
  readable,
  decompressHandlers: {
    zstd: (data, size) => {
      const out = decompress(data, new Uint8Array(Number(size)));
      if (out.length !== Number(size)) throw new Error(`zstd: ${out.length} bytes, expected ${size}`);
      return out;
    },
  },
});
const channels = {};
for (const [id, c] of reader.channelsById) {
  channels[id] = {
    topic: c.topic,
    message_encoding: c.messageEncoding,
    schema: reader.schemasById.get(c.schemaId)?.name ?? null,
  };
}
const first = reader.chunkIndexes.reduce(
  (m, c) => (c.messageStartTime < m ? c.messageStartTime : m),
  reader.chunkIndexes[0].messageStartTime,
);
const startTime = first + BigInt(Math.round(Number(startArg) * 1e9));
const endTime = startTime + BigInt(Math.round(Number(lengthArg) * 1e9)) - 1n;
const perTopic = {};
let last = null;
let ordered = true;
let firstRead = null;
let decoded = 0;
for await (const m of reader.readMessages({ startTime, endTime })) {
  const topic = reader.channelsById.get(m.channelId).topic;
  perTopic[topic] = (perTopic[topic] ?? 0) + 1;
  if (last !== null && m.logTime < last) ordered = false;
  if (firstRead === null) firstRead = m.logTime;
  last = m.logTime;
  if (channels[m.channelId].message_encoding === "json") {
    JSON.parse(new TextDecoder().decode(m.data));
    decoded += 1;
  }
}
await handle.close();
console.log(
  JSON.stringify({
    channels,
    chunks: reader.chunkIndexes.length,
    compressions: [...new Set(reader.chunkIndexes.map((c) => c.compression))],
    window: {
      start_ns: startTime.toString(),
      end_ns: endTime.toString(),
      per_topic: perTopic,
      first_ns: firstRead?.toString() ?? null,
      last_ns: last?.toString() ?? null,
      in_time_order: ordered,
      json_decoded: decoded,
    },
  }),
);
