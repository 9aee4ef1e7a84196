#!/usr/bin/env python3
"""What the ground link costs with five viewers: a paced run of the simulation
profile with five Foxglove WebSocket viewers connected for the whole run, against the same run
without the ground link.

    python3 bench/ground_viewers.py [--duration 600] [--viewers 5] [--out bench/report-ground]

Needs the release binaries (cargo build --release) and Python's `websockets` package. Each run
is `testbed run --profile <simulation> --paced --duration D --json`; the runs go one after the
other (never at once: they would share the two cores). Measured per run:

- deadline misses: the controller's count, from the run summary;
- CPU time of every process of the run (utime + stime from /proc/<pid>/stat, sampled every
  second for the launcher's descendants, the last value of each process kept);
- with the link: per viewer, the bytes and messages received (WebSocket payloads), and the
  link's own counters (`GET /stats`) at the end.

The viewers subscribe to every channel the link advertises, at the link's default rate
(`ground.viewer_rate_hz`), as a Foxglove or ground page client would. Writes report.json and
report.md to --out. Times are wall clock on a shared machine: compare the two runs of one
report, not reports of different days.
"""

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TESTBED = ROOT / "target" / "release" / "testbed"
CLK_TCK = os.sysconf("SC_CLK_TCK")


def profile_without_ground_link(text):
    """The profile's text without its `ground-link` process block."""
    head, *blocks = re.split(r"(?m)^(?=\[\[process\]\])", text)
    kept = [b for b in blocks if not re.search(r'(?m)^name\s*=\s*"ground-link"', b)]
    if len(kept) != len(blocks) - 1:
        raise SystemExit("the profile has no ground-link process block to remove")
    return head + "".join(kept)


def descendants(root_pid):
    """Pids of every live descendant of root_pid, with their comm and CPU ticks."""
    parent, info = {}, {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = open(f"/proc/{entry}/stat").read()
        except OSError:
            continue
        comm = stat[stat.index("(") + 1 : stat.rindex(")")]
        fields = stat[stat.rindex(")") + 2 :].split()
        pid = int(entry)
        parent[pid] = int(fields[1])
        info[pid] = (comm, int(fields[11]) + int(fields[12]))
    out = {}
    for pid in info:
        p = pid
        while p in parent and p != root_pid and p > 1:
            p = parent[p]
        if p == root_pid and pid != root_pid:
            out[pid] = info[pid]
    return out


class Viewer(threading.Thread):
    def __init__(self, url, index):
        super().__init__(daemon=True)
        self.url, self.index = url, index
        self.bytes = self.messages = 0
        self.channels = 0
        self.error = None
        self.stop = threading.Event()

    def run(self):
        from websockets.sync.client import connect

        try:
            with connect(self.url, subprotocols=["foxglove.websocket.v1"],
                         max_size=None, open_timeout=10) as ws:
                channels = []
                deadline = time.monotonic() + 10
                while not channels and time.monotonic() < deadline:
                    msg = ws.recv(timeout=10)
                    if isinstance(msg, str):
                        m = json.loads(msg)
                        if m.get("op") == "advertise":
                            channels = m["channels"]
                self.channels = len(channels)
                subs = [{"id": i + 1, "channelId": c["id"]} for i, c in enumerate(channels)]
                ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
                while not self.stop.is_set():
                    try:
                        msg = ws.recv(timeout=1)
                    except TimeoutError:
                        continue
                    self.messages += 1
                    self.bytes += len(msg)
        except Exception as e:  # the link closes when the run ends
            self.error = f"{type(e).__name__}: {e}"


def run(profile, duration, viewers, scratch, label):
    log = scratch / f"{label}.mcap"
    cmd = [str(TESTBED), "run", "--profile", str(profile), "--paced", "--duration",
           str(duration), "--log", str(log), "--json", "--no-progress"]
    print(f"[{label}] {' '.join(cmd)}", file=sys.stderr)
    child = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    cpu = {}
    started = time.monotonic()
    clients = []
    info_path = log.with_suffix(".ground.json")
    stats = None
    while child.poll() is None:
        for pid, (comm, ticks) in descendants(child.pid).items():
            cpu[pid] = (comm, ticks)
        if viewers and not clients and info_path.exists():
            try:
                info = json.loads(info_path.read_text())
            except ValueError:
                info = None
            if info:
                clients = [Viewer(info["ws"], i) for i in range(viewers)]
                for c in clients:
                    c.start()
                stats_url = info["url"] + "stats"
        if clients and time.monotonic() - started > duration - 5 and stats is None:
            try:
                stats = json.loads(urllib.request.urlopen(stats_url, timeout=2).read())
            except OSError:
                pass
        time.sleep(1.0)
    wall = time.monotonic() - started
    out, err = child.communicate()
    for c in clients:
        c.stop.set()
    for c in clients:
        c.join(timeout=5)
    if child.returncode != 0:
        raise SystemExit(f"[{label}] testbed run failed ({child.returncode}):\n{err[-2000:]}")
    summary = json.loads(out)
    per_process = {}
    for comm, ticks in cpu.values():
        per_process[comm] = per_process.get(comm, 0.0) + ticks / CLK_TCK
    result = {
        "label": label,
        "wall_s": round(wall, 1),
        "deadline_misses": summary.get("deadline_misses"),
        "cpu_s_total": round(sum(per_process.values()), 2),
        "cpu_s_per_process": {k: round(v, 2) for k, v in sorted(per_process.items())},
    }
    if viewers:
        result["viewers"] = [
            {"viewer": c.index, "channels": c.channels, "messages": c.messages,
             "bytes": c.bytes, "bytes_per_s": round(c.bytes / duration),
             "messages_per_s": round(c.messages / duration, 1), "error": c.error}
            for c in clients
        ]
        result["link_stats"] = stats
    return result


def markdown(report):
    a, b = report["without_link"], report["with_link"]
    d = report["duration_s"]
    link_cpu = b["cpu_s_per_process"].get("ground-link", 0.0)
    lines = [
        "# The ground link with five viewers",
        "",
        f"Paced `simulation` runs of {d:.0f} s, one after the other on this machine (2 shared "
        f"cores), measured by `python3 bench/ground_viewers.py --duration {d:.0f}`. "
        f"Recorded {report['date']}.",
        "",
        "| | without the ground link | with it, {} viewers |".format(len(b["viewers"])),
        "|---|---|---|",
        f"| deadline misses | {a['deadline_misses']} | {b['deadline_misses']} |",
        f"| CPU time of the whole pipeline, s | {a['cpu_s_total']} | {b['cpu_s_total']} |",
        f"| of which the ground link, s | – | {link_cpu} |",
        f"| ground link, % of one core | – | {100 * link_cpu / d:.2f} % |",
        f"| ground link per viewer, % of one core | – | {100 * link_cpu / d / len(b['viewers']):.2f} % |",
        "",
        "Per viewer (subscribed to every channel at the link's default rate):",
        "",
        "| viewer | channels | messages/s | bytes/s | kbit/s |",
        "|---|---|---|---|---|",
    ]
    for v in b["viewers"]:
        lines.append(f"| {v['viewer']} | {v['channels']} | {v['messages_per_s']} | "
                     f"{v['bytes_per_s']} | {8 * v['bytes_per_s'] / 1000:.1f} |")
    lines += ["", "CPU time per process, s:", "", "| process | without | with |", "|---|---|---|"]
    for name in sorted(set(a["cpu_s_per_process"]) | set(b["cpu_s_per_process"])):
        lines.append(f"| {name} | {a['cpu_s_per_process'].get(name, '–')} | "
                     f"{b['cpu_s_per_process'].get(name, '–')} |")
    if b.get("link_stats"):
        lines += ["", "The link's counters near the end of the run (`GET /stats`):", "",
                  "```json", json.dumps(b["link_stats"], indent=1), "```"]
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--viewers", type=int, default=5)
    ap.add_argument("--profile", default=str(ROOT / "launch" / "profiles" / "simulation.toml"))
    ap.add_argument("--out", default=str(ROOT / "bench" / "report-ground"))
    args = ap.parse_args()
    if not TESTBED.exists():
        raise SystemExit(f"no {TESTBED}: cargo build --release first")
    profile = Path(args.profile)
    with tempfile.TemporaryDirectory(prefix="ground-bench-") as tmp:
        scratch = Path(tmp)
        # Beside the original, so its relative paths (run configuration) still resolve.
        bare = profile.with_name(f".{profile.stem}-without-ground-link.toml")
        bare.write_text(profile_without_ground_link(profile.read_text()))
        try:
            without = run(bare, args.duration, 0, scratch, "without_link")
        finally:
            bare.unlink()
        with_link = run(profile, args.duration, args.viewers, scratch, "with_link")
    report = {
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "duration_s": args.duration,
        "without_link": without,
        "with_link": with_link,
    }
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "report.json").write_text(json.dumps(report, indent=1) + "\n")
    (out / "report.md").write_text(markdown(report))
    print(markdown(report))
    bad = [v for v in with_link["viewers"] if v["messages"] == 0]
    if bad:
        raise SystemExit(f"viewers received nothing: {bad}")


if __name__ == "__main__":
    main()
