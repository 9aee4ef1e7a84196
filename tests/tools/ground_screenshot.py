#!/usr/bin/env python3
"""Screenshot of the ground page during a run (the README's figure).

    python3 tests/tools/ground_screenshot.py OUT.png [--wait 40] [--duration 90]

Starts `testbed run --profile simulation --paced` (release binaries), opens the ground page in
headless Chromium through the DevTools protocol, lets the run go for --wait seconds of wall
time, captures the page and stops the run. Needs `chromium` and Python's `websockets`.
"""
import argparse
import base64
import json
import signal
import subprocess
import tempfile
import time
import urllib.request
from pathlib import Path

from websockets.sync.client import connect

ROOT = Path(__file__).resolve().parent.parent.parent

ap = argparse.ArgumentParser()
ap.add_argument("out")
ap.add_argument("--wait", type=float, default=40)
ap.add_argument("--duration", type=float, default=90)
args = ap.parse_args()

with tempfile.TemporaryDirectory(prefix="ground-shot-") as tmp:
    log = Path(tmp) / "run.mcap"
    run = subprocess.Popen([str(ROOT / "target/release/testbed"), "run", "--profile", "simulation",
                            "--paced", "--duration", str(args.duration), "--log", str(log),
                            "--no-progress"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    info_path = log.with_suffix(".ground.json")
    for _ in range(300):
        if info_path.exists() and info_path.stat().st_size > 0:
            break
        time.sleep(0.1)
    info = json.loads(info_path.read_text())
    browser = subprocess.Popen(["chromium", "--headless", "--no-sandbox", "--disable-gpu",
                                "--hide-scrollbars", "--window-size=1440,1100",
                                "--remote-debugging-port=9333", f"--user-data-dir={tmp}/profile",
                                "about:blank"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        for _ in range(100):
            try:
                targets = json.loads(urllib.request.urlopen("http://127.0.0.1:9333/json").read())
                page = next(t for t in targets if t["type"] == "page")
                break
            except (OSError, StopIteration):
                time.sleep(0.2)
        with connect(page["webSocketDebuggerUrl"], max_size=None) as ws:
            def call(i, method, params=None):
                ws.send(json.dumps({"id": i, "method": method, "params": params or {}}))
                while True:
                    m = json.loads(ws.recv(timeout=60))
                    if m.get("id") == i:
                        return m.get("result", {})
            call(1, "Page.navigate", {"url": f"{info['url']}#token={info['token']}"})
            time.sleep(args.wait)
            shot = call(2, "Page.captureScreenshot", {"format": "png"})
            Path(args.out).write_bytes(base64.b64decode(shot["data"]))
    finally:
        browser.terminate()
        run.send_signal(signal.SIGINT)
        run.wait(timeout=30)
print(f"wrote {args.out}")
