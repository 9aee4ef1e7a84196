#!/usr/bin/env python3
"""Compare two run logs (MCAP) record by record.

Every message on every topic must be equal byte for byte, in the same order per topic. The run
configuration attachment and metadata are left out (they name paths, which differ between two
runs). Usage: compare_logs.py A.mcap B.mcap [--tolerance X]

With --tolerance, JSON messages may differ in floating-point fields by at most X (absolute);
every other field must still be equal. Exit status 0 when the logs agree, 1 otherwise.
"""
import argparse
import json
import sys
from collections import defaultdict

from mcap.reader import make_reader


def load(path):
    """Messages per topic as (time on the run clock, data). Log times are the run's wall-clock
    start plus the run clock; the start (metadata `start_time_ns`, absent in older logs) is
    taken off so two runs compare. The channels on Foxglove's schemas (`foxglove.*`: transforms,
    pose, events, scene) are left out: they are derived from the samples, and their time stamps
    carry the start."""
    per_topic = defaultdict(list)
    with open(path, "rb") as f:
        reader = make_reader(f)
        start = 0
        for m in reader.iter_metadata():
            if m.name == "testbed.run":
                start = int(m.metadata.get("start_time_ns", "0"))
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            if schema is not None and schema.name.startswith("foxglove."):
                continue
            per_topic[channel.topic].append((message.log_time - start, message.data))
    return per_topic


def worst_difference(a, b):
    """Largest absolute difference between two JSON values of the same shape, or None if their
    shapes or non-float fields differ."""
    if isinstance(a, dict) and isinstance(b, dict):
        if a.keys() != b.keys():
            return None
        worst = 0.0
        for k in a:
            d = worst_difference(a[k], b[k])
            if d is None:
                return None
            worst = max(worst, d)
        return worst
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return None
        worst = 0.0
        for x, y in zip(a, b):
            d = worst_difference(x, y)
            if d is None:
                return None
            worst = max(worst, d)
        return worst
    if isinstance(a, float) or isinstance(b, float):
        return abs(float(a) - float(b))
    return 0.0 if a == b else None


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("a")
    parser.add_argument("b")
    parser.add_argument("--tolerance", type=float, default=None)
    args = parser.parse_args()
    a, b = load(args.a), load(args.b)
    ok = True
    if a.keys() != b.keys():
        print(f"topics differ: only in A {sorted(a.keys() - b.keys())}, only in B {sorted(b.keys() - a.keys())}")
        ok = False
    total, worst = 0, 0.0
    for topic in sorted(a.keys() & b.keys()):
        ra, rb = a[topic], b[topic]
        if len(ra) != len(rb):
            print(f"{topic}: {len(ra)} records in A, {len(rb)} in B")
            ok = False
            continue
        for i, ((ta, da), (tb, db)) in enumerate(zip(ra, rb)):
            total += 1
            if ta == tb and da == db:
                continue
            if args.tolerance is not None and ta == tb:
                d = worst_difference(json.loads(da), json.loads(db))
                if d is not None and d <= args.tolerance:
                    worst = max(worst, d)
                    continue
            print(f"{topic}: record {i} differs (log time {ta} vs {tb})")
            ok = False
            break
    if ok:
        extra = f", worst float difference {worst:.3g}" if args.tolerance is not None else " byte for byte"
        print(f"logs agree: {total} records on {len(a)} topics{extra}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
