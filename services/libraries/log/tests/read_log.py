#!/usr/bin/env python3
"""Reads a testbed run log with the standard Python `mcap` package; prints a JSON report.

    read_log.py summary FILE   file written and finished by testbed-log: header, schemas,
                               channels, statistics, per-topic message counts (every message
                               JSON-decoded and checked against its schema's properties),
                               attachments, metadata
    read_log.py stream FILE    possibly truncated file, read with StreamReader: every complete
                               message (topic, time_ns, sequence) and how the stream ended

Needs `pip install 'mcap>=1.1,<2'`.
"""

import json
import sys

from mcap.reader import make_reader
from mcap.records import Channel, Message, Schema
from mcap.stream_reader import StreamReader


def check_message(schema, channel, message, start_time_ns):
    data = json.loads(message.data)
    schema_doc = json.loads(schema.data)
    props = schema_doc["properties"]
    if schema.name.startswith("foxglove."):
        # Derived from a sample: stamped with the log time, fields as Foxglove's schema lists them.
        if set(data) != set(props):
            raise SystemExit(f"{channel.topic}: fields {sorted(data)} != schema {sorted(props)}")
        stamped = data["entities"][0] if schema.name == "foxglove.SceneUpdate" else data
        stamp = stamped["timestamp"]["sec"] * 10**9 + stamped["timestamp"]["nsec"]
        if not (stamp == message.log_time == message.publish_time):
            raise SystemExit(f"{channel.topic}: timestamp {stamp} != log_time")
        return
    if set(data) != set(props) or set(schema_doc["required"]) != set(props):
        raise SystemExit(f"{channel.topic}: fields {sorted(data)} != schema {sorted(props)}")
    header = data["header"]
    if not (start_time_ns + header["time_ns"] == message.log_time == message.publish_time):
        raise SystemExit(f"{channel.topic}: start {start_time_ns} + header.time_ns "
                         f"{header['time_ns']} != log_time {message.log_time}")
    if message.sequence != header["sequence"] % 2**32:
        raise SystemExit(f"{channel.topic}: MCAP sequence != header.sequence")


def summary(path):
    with open(path, "rb") as f:
        reader = make_reader(f)
        header = reader.get_header()
        s = reader.get_summary()
        out = {
            "profile": header.profile,
            "library": header.library,
            "schemas": {
                str(i): {"name": sc.name, "encoding": sc.encoding, "data": json.loads(sc.data)}
                for i, sc in s.schemas.items()
            },
            "channels": {
                str(i): {
                    "topic": ch.topic,
                    "schema_id": ch.schema_id,
                    "message_encoding": ch.message_encoding,
                }
                for i, ch in s.channels.items()
            },
            "statistics": {
                "message_count": s.statistics.message_count,
                "channel_message_counts": {
                    str(k): v for k, v in s.statistics.channel_message_counts.items()
                },
                "attachment_count": s.statistics.attachment_count,
                "metadata_count": s.statistics.metadata_count,
            },
        }
        out["chunk_indexes"] = len(s.chunk_indexes)
        run = next(m for m in reader.iter_metadata() if m.name == "testbed.run")
        start_time_ns = int(run.metadata["start_time_ns"])
        counts = {}
        times = []
        for schema, channel, message in reader.iter_messages(log_time_order=True):
            check_message(schema, channel, message, start_time_ns)
            times.append(message.log_time)
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
        out["messages"] = counts
        # Seeking through the chunk index: the messages of the second half of the run only.
        if times:
            middle = times[len(times) // 2]
            out["from_middle"] = sum(1 for _ in reader.iter_messages(start_time=middle))
            out["at_or_after_middle"] = sum(1 for t in times if t >= middle)
        out["attachments"] = [
            {"name": a.name, "media_type": a.media_type, "data": a.data.decode("utf-8"),
             "log_time": a.log_time, "create_time": a.create_time}
            for a in reader.iter_attachments()
        ]
        out["metadata"] = [
            {"name": m.name, "metadata": dict(m.metadata)} for m in reader.iter_metadata()
        ]
    print(json.dumps(out))


def stream(path):
    schemas = {}
    channels = {}
    messages = []
    ended = "footer"
    with open(path, "rb") as f:
        try:
            for record in StreamReader(f).records:
                if isinstance(record, Schema):
                    schemas[record.id] = record.name
                elif isinstance(record, Channel):
                    channels[record.id] = (record.topic, schemas.get(record.schema_id, ""))
                elif isinstance(record, Message):
                    topic, schema = channels[record.channel_id]
                    if schema.startswith("foxglove."):
                        continue  # derived for Foxglove's panels, not a sample
                    try:
                        header = json.loads(record.data)["header"]
                    except ValueError:
                        # StreamReader hands out a cut message with its short data; a complete
                        # record always holds valid JSON.
                        ended = "partial message"
                        break
                    messages.append([topic, header["time_ns"],
                                     header["sequence"]])
        except Exception as e:  # EndOfFile, or struct.error on a cut record header
            ended = type(e).__name__
    print(json.dumps({"messages": messages, "ended": ended}))


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in ("summary", "stream"):
        raise SystemExit(__doc__)
    {"summary": summary, "stream": stream}[sys.argv[1]](sys.argv[2])
