#!/usr/bin/env python3
"""How small a run's log can get: a finished log's messages re-encoded in other ways and
compressed as `testbed-log` compresses its chunks, beside the log as written.

    python3 bench/log_floor.py RUN.mcap [--window-s 10] [--level 1]

Needs Python's `mcap` and `zstandard` packages (`.ci/run` installs them). The log is one of
`testbed run` (JSON messages, zstd chunks of 10 s of log time, grouped by channel). For every
encoding below, the chunks are modelled as the logger writes them: each window of `--window-s`
of log time (the logger's: 10 s) is one zstd frame at `--level` (the logger's: 1) holding the
window's message records (each with its 31-byte record header) grouped by channel; every
message adds its 16-byte message index entry (log time and offset: what `@mcap/core`'s indexed
reader reads to find a message). Schemas, chunk headers and the summary are left out (some
0.2 MB), so the first row, the same JSON recompressed, shows how close the model is to the
file.

Encodings (a field's bytes without its name: as a protobuf message with packed repeated fields,
less the one-byte tags):

- `json`: the messages as written;
- `binary f64`: every number as 8 bytes, integers as varints, exact;
- `binary f32`: numbers as 4 bytes except the estimate's quaternion and times, not exact;
- `binary, f64 inputs, f32 others`: exact for what replay and identification read (sensors and
  actuators), single precision for the estimate, the controller's status and the truth;
- `binary f64, covariance triangle`: exact; the estimate's covariance as its upper triangle
  (21 of 36 values: the filter keeps it exactly symmetric, so the other 15 follow);
- `binary f64, covariance f32 triangle`: exact but for the estimate's covariance, its upper
  triangle in single precision;
- `... without views`: the same without the derived Foxglove views (`testbed/tf/*`,
  `testbed/pose/*`) and the simulation clock: fewer messages.

Prints one row per encoding and the messages' share: the message indexes alone are 16 bytes a
message whatever the encoding.
"""

import argparse
import collections
import json
import os
import struct
import sys

import zstandard
from mcap.reader import make_reader

INDEX_ENTRY = 16
# A message record's header: opcode, record length, channel id, sequence, log and publish time.
RECORD_HEADER = struct.Struct("<BQHIQQ")
EXACT_FIELDS = {"time_ns", "sec", "nsec"}
INPUTS = ("testbed/sensors/", "testbed/actuators/")
VIEWS = ("testbed/tf/", "testbed/pose/", "testbed/sim/clock")


def varint(n):
    n = (n << 1) ^ (n >> 63) if n < 0 else n << 1  # zigzag, as sint64
    out = bytearray()
    while True:
        byte, n = n & 0x7F, n >> 7
        out.append(byte | (0x80 if n else 0))
        if not n:
            return bytes(out)


def binary(value, single, exact=False):
    """The value's bytes: numbers fixed-width (f32 when `single` and not `exact`)."""
    if isinstance(value, dict):
        return b"".join(binary(v, single, exact or k in EXACT_FIELDS) for k, v in value.items())
    if isinstance(value, list):
        return b"".join(binary(v, single, exact) for v in value)
    if isinstance(value, bool) or value is None:
        return b"\0"
    if isinstance(value, int):
        return varint(value)
    if isinstance(value, float):
        return struct.pack("<f" if single and not exact else "<d", value)
    return value.encode()


def encoders():
    def json_bytes(topic, data, message):
        return data

    def f64(topic, data, message):
        return binary(message, single=False)

    def f32(topic, data, message):
        if topic.endswith("attitude_estimate"):
            quaternion = struct.pack("<4d", *message["quaternion"])
            rest = {k: v for k, v in message.items() if k != "quaternion"}
            return quaternion + binary(rest, single=True)
        return binary(message, single=True)

    def covariance_triangle(single):
        def encode(topic, data, message):
            if not topic.endswith("attitude_estimate"):
                return f64(topic, data, message)
            covariance = message["covariance"]
            triangle = [covariance[6 * r + c] for r in range(6) for c in range(r, 6)]
            rest = {k: v for k, v in message.items() if k != "covariance"}
            return binary(rest, single=False) + struct.pack("<21f" if single else "<21d", *triangle)

        return encode

    def inputs_exact(topic, data, message):
        return f64(topic, data, message) if topic.startswith(INPUTS) else f32(topic, data, message)

    def without_views(encode):
        return lambda topic, data, message: None if topic.startswith(VIEWS) else encode(topic, data, message)

    return [
        ("json (as written)", json_bytes),
        ("binary f64 (exact)", f64),
        ("binary f32", f32),
        ("binary, f64 inputs, f32 others", inputs_exact),
        ("json without views", without_views(json_bytes)),
        ("binary f64 without views", without_views(f64)),
        ("binary f64, covariance triangle, without views", without_views(covariance_triangle(False))),
        ("binary f64, covariance f32 triangle, without views", without_views(covariance_triangle(True))),
        ("binary, f64 inputs, f32 others, without views", without_views(inputs_exact)),
        ("binary f32 without views", without_views(f32)),
    ]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("log", help="a finished MCAP log of testbed run")
    parser.add_argument("--window-s", type=float, default=10.0, help="chunk length, s of log time (the logger's: 10)")
    parser.add_argument("--level", type=int, default=1, help="zstd level (the logger's: 1)")
    args = parser.parse_args()

    window_ns = int(args.window_s * 1e9)
    windows = collections.defaultdict(lambda: collections.defaultdict(list))
    with open(args.log, "rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            windows[message.log_time // window_ns][(channel.id, channel.topic)].append(
                (message.sequence, message.log_time, message.data, json.loads(message.data))
            )
    compressor = zstandard.ZstdCompressor(level=args.level)
    file_mb = os.path.getsize(args.log) / 1e6

    print(f"{args.log}: {file_mb:.2f} MB; chunks of {args.window_s:g} s, zstd level {args.level}")
    print(f"| encoding | messages | index, MB | data, MB | total, MB |")
    print(f"|---|---:|---:|---:|---:|")
    for name, encode in encoders():
        messages = data = 0
        for channels in windows.values():
            records = []
            for (channel_id, topic), rows in channels.items():
                for sequence, log_time, payload, message in rows:
                    encoded = encode(topic, payload, message)
                    if encoded is None:
                        continue
                    header = RECORD_HEADER.pack(
                        5, 22 + len(encoded), channel_id, sequence & 0xFFFFFFFF, log_time, log_time
                    )
                    records.append(header + encoded)
            if records:
                messages += len(records)
                data += len(compressor.compress(b"".join(records)))
        index = messages * INDEX_ENTRY
        print(f"| {name} | {messages} | {index / 1e6:.2f} | {data / 1e6:.2f} | {(index + data) / 1e6:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
