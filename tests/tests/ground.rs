//! The ground station end to end: a paced simulation run with the ground link, the
//! ground page in headless Chromium (Debian's `chromium`, driven over the DevTools protocol), an
//! independent client of the Foxglove WebSocket protocol (tungstenite), and random input.
//!
//! Checked: the page's displayed estimate updates and is a sample of the run log (same time,
//! same quaternion); a mode command typed in the page changes the controller's mode and is in
//! the log with its acknowledgement; a wrong token and an out-of-limit target are rejected
//! with their reasons (in the page and in the log); closing and reopening the page reconnects;
//! an independent client gets decimated data at the rate it asked for; random frames, wrong
//! types and huge messages are counted and dropped and the link goes on serving; a huge
//! message's sender and, at the end of the run, every viewer get a close frame (1009, 1001).
//!
//! Conformance with clients others wrote: Foxglove's own `FoxgloveClient`
//! (`tests/js/foxglove_client.mjs`, `npm ci --prefix tests/js`) commands the controller the
//! standard way and validates every channel against its advertised JSON Schema and the
//! `foxglove.*` ones against `@foxglove/schemas`; over `wss://` too, with the page over
//! `https://` in Chromium; a plain connection to the TLS link, a watcher's command and an
//! earlier run's token are refused and logged with the peer's address.

use ipc_types::{
    AttitudeEstimate, ControllerMode, ControllerStatus, GroundAckStatus, GroundCommand,
    GroundCommandAck, GroundCommandKind,
};
use proptest::prelude::*;
use proptest::strategy::ValueTree;
use proptest::test_runner::{Config, TestRunner};
use serde_json::{Value, json};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use testbed_e2e::{Scratch, binary, profile};
use testbed_log::{LogEncode, RunLog};
use tungstenite::client::IntoClientRequest;
use tungstenite::protocol::frame::coding::CloseCode;
use tungstenite::stream::MaybeTlsStream;
use tungstenite::{Message, WebSocket};

type Ws = WebSocket<MaybeTlsStream<TcpStream>>;

/// Waits until `f` gives a value, or panics naming `what`.
fn wait_for<T>(what: &str, timeout: Duration, mut f: impl FnMut() -> Option<T>) -> T {
    let start = Instant::now();
    loop {
        if let Some(v) = f() {
            return v;
        }
        assert!(start.elapsed() < timeout, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// A paced run of the simulation profile; its ground link's address and token.
struct Run {
    child: Child,
    log: PathBuf,
    addr: String,
    token: String,
}

fn start_run(dir: &Path, duration_s: u32) -> Run {
    start_run_with(dir, duration_s, None)
}

/// [`start_run`] with the run configuration `config` (TOML) if given.
fn start_run_with(dir: &Path, duration_s: u32, config: Option<&Path>) -> Run {
    let log = dir.join("ground.mcap");
    let mut command = Command::new(binary("testbed"));
    command
        .args(["run", "--paced", "--no-progress", "--json", "--profile"])
        .arg(profile("simulation"))
        .args(["--duration", &duration_s.to_string(), "--log"])
        .arg(&log);
    if let Some(config) = config {
        command.arg("--config").arg(config);
    }
    let child = command
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starting testbed run");
    let info_path = log.with_extension("ground.json");
    let info: Value = wait_for("the ground link", Duration::from_secs(60), || {
        serde_json::from_slice(&std::fs::read(&info_path).ok()?).ok()
    });
    let url = info["url"].as_str().unwrap();
    let addr = url
        .trim_start_matches("http://")
        .trim_start_matches("https://")
        .trim_end_matches('/')
        .to_owned();
    Run {
        child,
        log,
        addr,
        token: info["token"].as_str().unwrap().to_owned(),
    }
}

/// The body of `GET path` from `addr`. Reads exactly `Content-Length` bytes when the server
/// gives it: Chromium's DevTools server keeps the connection open after the body.
fn http_get(addr: &str, path: &str) -> String {
    let mut s = TcpStream::connect(addr).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut reader = BufReader::new(s);
    let mut content_length = None;
    loop {
        let mut line = String::new();
        if reader.read_line(&mut line).unwrap() == 0 || line == "\r\n" {
            break;
        }
        if let Some((name, value)) = line.split_once(':')
            && name.eq_ignore_ascii_case("content-length")
        {
            content_length = value.trim().parse::<usize>().ok();
        }
    }
    let mut body = Vec::new();
    match content_length {
        Some(n) => {
            body.resize(n, 0);
            reader.read_exact(&mut body).unwrap();
        }
        None => {
            reader.read_to_end(&mut body).unwrap();
        }
    }
    String::from_utf8_lossy(&body).into_owned()
}

fn stats(addr: &str) -> Value {
    serde_json::from_str(&http_get(addr, "/stats")).unwrap()
}

/// A Foxglove WebSocket protocol client: connected, `serverInfo` and `advertise` read.
fn foxglove_client(addr: &str, query: &str) -> (Ws, Value, Vec<Value>) {
    let mut request = format!("ws://{addr}/{query}")
        .into_client_request()
        .unwrap();
    request.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        "foxglove.websocket.v1".parse().unwrap(),
    );
    let (mut ws, response) = tungstenite::connect(request).unwrap();
    assert_eq!(
        response.headers()["sec-websocket-protocol"],
        "foxglove.websocket.v1"
    );
    let mut texts = Vec::new();
    while texts.len() < 2 {
        if let Message::Text(t) = ws.read().unwrap() {
            texts.push(serde_json::from_str::<Value>(t.as_str()).unwrap());
        }
    }
    assert_eq!(texts[0]["op"], "serverInfo");
    assert_eq!(texts[1]["op"], "advertise");
    let channels = texts[1]["channels"].as_array().unwrap().clone();
    (ws, texts[0].clone(), channels)
}

fn channel_id(channels: &[Value], topic: &str) -> u64 {
    channels
        .iter()
        .find(|c| c["topic"] == topic)
        .unwrap_or_else(|| panic!("{topic} not advertised"))["id"]
        .as_u64()
        .unwrap()
}

/// The next `messageData` of subscription `sub`: (time, JSON).
fn next_message(ws: &mut Ws, sub: u32) -> (u64, Value) {
    loop {
        if let Message::Binary(b) = ws.read().unwrap()
            && b[0] == 1
            && u32::from_le_bytes(b[1..5].try_into().unwrap()) == sub
        {
            let t = u64::from_le_bytes(b[5..13].try_into().unwrap());
            return (t, serde_json::from_slice(&b[13..]).unwrap());
        }
    }
}

/// Chromium over the DevTools protocol: one page.
struct Browser {
    child: Child,
    page: Ws,
    next_id: u64,
    _profile: Scratch,
}

impl Browser {
    fn start() -> Self {
        Self::start_with(&[])
    }

    /// Chromium with the `extra` switches.
    fn start_with(extra: &[&str]) -> Self {
        let profile = Scratch::new("ground-chromium");
        let mut child = Command::new("chromium")
            .args([
                "--headless=new",
                "--no-sandbox",
                "--disable-gpu",
                "--no-first-run",
                "--remote-debugging-port=0",
                "--window-size=1400,1000",
            ])
            .args(extra)
            .arg(format!("--user-data-dir={}", profile.path().display()))
            .arg("about:blank")
            .stderr(Stdio::piped())
            .stdout(Stdio::null())
            .spawn()
            .expect("starting chromium (apt-get install chromium; .ci/run installs it)");
        let stderr = child.stderr.take().unwrap();
        let mut lines = BufReader::new(stderr).lines();
        let browser_url = loop {
            let line = lines.next().expect("chromium exited").unwrap();
            if let Some(url) = line.strip_prefix("DevTools listening on ") {
                break url.to_owned();
            }
        };
        // Keep reading chromium's stderr so it never blocks on a full pipe.
        std::thread::spawn(move || for _ in lines {});
        let host = browser_url
            .trim_start_matches("ws://")
            .split('/')
            .next()
            .unwrap()
            .to_owned();
        let list: Value = wait_for("the page target", Duration::from_secs(20), || {
            let list: Value = serde_json::from_str(&http_get(&host, "/json/list")).ok()?;
            list.as_array()?
                .iter()
                .any(|t| t["type"] == "page")
                .then_some(list)
        });
        let page_url = list
            .as_array()
            .unwrap()
            .iter()
            .find(|t| t["type"] == "page")
            .unwrap()["webSocketDebuggerUrl"]
            .as_str()
            .unwrap()
            .to_owned();
        let (page, _) = tungstenite::connect(page_url).unwrap();
        Self {
            child,
            page,
            next_id: 1,
            _profile: profile,
        }
    }

    fn call(&mut self, method: &str, params: Value) -> Value {
        let id = self.next_id;
        self.next_id += 1;
        let request = json!({"id": id, "method": method, "params": params});
        self.page
            .send(Message::Text(request.to_string().into()))
            .unwrap();
        loop {
            if let Message::Text(t) = self.page.read().unwrap() {
                let v: Value = serde_json::from_str(t.as_str()).unwrap();
                if v["id"] == id {
                    assert!(v.get("error").is_none(), "{method}: {v}");
                    return v["result"].clone();
                }
            }
        }
    }

    /// Evaluates `expression` in the page; its value.
    fn eval(&mut self, expression: &str) -> Value {
        let r = self.call(
            "Runtime.evaluate",
            json!({"expression": expression, "returnByValue": true}),
        );
        r["result"]["value"].clone()
    }

    fn open(&mut self, url: &str) {
        self.call("Page.navigate", json!({"url": url}));
    }

    fn text(&mut self, id: &str) -> String {
        self.eval(&format!(
            "document.getElementById('{id}').dataset.value || ''"
        ))
        .as_str()
        .unwrap_or_default()
        .to_owned()
    }

    /// The page's displayed estimate: its time and quaternion, read in one evaluation (two
    /// reads could straddle the arrival of the next estimate and pair one estimate's time
    /// with the next one's quaternion).
    fn estimate(&mut self) -> Option<(u64, [f64; 4])> {
        let both = self.eval(
            "[document.getElementById('est-time').dataset.value || '', \
              document.getElementById('est-q').dataset.value || '']",
        );
        let t: u64 = both[0].as_str()?.parse().ok()?;
        let q: Vec<f64> = serde_json::from_str(both[1].as_str()?).ok()?;
        Some((t, q.try_into().ok()?))
    }

    /// Types a command into the page's form and clicks `button`; the result line it shows.
    fn command(&mut self, fill: &str, button: &str, expect: &str) -> String {
        self.eval(&format!(
            "(() => {{ {fill}; document.getElementById('{button}').click(); }})()"
        ));
        wait_for(expect, Duration::from_secs(10), || {
            let r = self.text("cmd-result");
            r.contains(expect).then_some(r)
        })
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The strings of a JSON array (none for anything else).
fn strings(v: &Value) -> Vec<&str> {
    v.as_array()
        .map_or_else(Vec::new, |a| a.iter().filter_map(Value::as_str).collect())
}

fn samples<T: LogEncode>(log: &Path) -> Vec<T> {
    RunLog::open(log)
        .unwrap()
        .samples::<T>()
        .unwrap()
        .map(Result::unwrap)
        .collect()
}

#[test]
fn the_ground_page_shows_the_run_and_commands_the_controller() {
    let scratch = Scratch::new("ground-page");
    let run = start_run(scratch.path(), 60);
    let mut browser = Browser::start();
    let page = format!("http://{}/#token={}", run.addr, run.token);
    browser.open(&page);

    // The displayed estimate updates.
    let first = wait_for("an estimate in the page", Duration::from_secs(20), || {
        browser.estimate()
    });
    let second = wait_for("a newer estimate", Duration::from_secs(10), || {
        browser.estimate().filter(|(t, _)| *t > first.0)
    });
    assert_eq!(
        browser.eval("document.getElementById('link').dataset.state"),
        "live"
    );
    // The plots are uPlot's: each with a legend naming every line, its unit on the value axis
    // and in the legend, drawing the run's samples (the thrusters' plot only with thrusters).
    let plots = wait_for("the plots drawn", Duration::from_secs(10), || {
        let v = browser.eval(
            "PLOTS.filter((p) => p.chart).map((p) => ({ id: p.id, unit: p.unit, \
               lines: p.series.length, points: p.chart.data[0].length, \
               legend: [...document.querySelectorAll(`#${p.id} .u-legend .u-series .u-label`)].map((e) => e.textContent), \
               axes: p.chart.axes.map((a) => a.label), \
               values: (p.chart.setCursor({ left: p.chart.bbox.width / devicePixelRatio - 2, top: 5 }), \
                 [...document.querySelectorAll(`#${p.id} .u-legend .u-series .u-value`)].map((e) => e.textContent)) }))",
        );
        let plots = v.as_array()?.clone();
        (plots.len() == 7 && plots.iter().all(|p| p["points"].as_u64() > Some(5))).then_some(plots)
    });
    for p in &plots {
        let legend = strings(&p["legend"]);
        // The first legend entry is the time axis.
        assert_eq!(legend.len() as u64, p["lines"].as_u64().unwrap() + 1, "{p}");
        // The axes are labelled with the time and the unit; the legend's values (at the cursor,
        // set near the newest samples) carry the unit.
        let unit = p["unit"].as_str().unwrap();
        assert_eq!(p["axes"], json!(["run time, s", unit]), "{p}");
        let values = strings(&p["values"]);
        assert!(
            values[0].ends_with(" s")
                && values[1..].iter().any(|v| v.ends_with(&format!(" {unit}"))),
            "{p}"
        );
    }
    assert!(
        plots[0]["legend"]
            .as_array()
            .unwrap()
            .iter()
            .any(|l| l == "estimate heading"),
        "{}",
        plots[0]
    );
    // The page's clock is the run clock (message times minus the run's start time): it is
    // at least the time of the estimate shown, and within the 60-s run.
    let shown_s: f64 = browser
        .text("simtime")
        .parse()
        .expect("the page shows the run time");
    assert!(
        shown_s + 0.1 >= second.0 as f64 * 1e-9 && shown_s <= 61.0,
        "page time {shown_s} s, estimate at {} ns",
        second.0
    );

    // A mode typed in the page: applied by the controller.
    let applied = browser.command(
        "document.getElementById('cmd-mode').value = 'rate_damping'",
        "send-mode",
        "applied",
    );
    assert!(applied.contains("RateDamping"), "{applied}");
    wait_for("the mode shown", Duration::from_secs(10), || {
        (browser.text("mode") == (ControllerMode::RateDamping as u32).to_string()).then_some(())
    });
    std::thread::sleep(Duration::from_millis(1100));

    // Wrong token, out-of-limit target: rejected with their reasons.
    let wrong = browser.command(
        "document.getElementById('token').value = 'not-the-token'; document.getElementById('cmd-mode').value = 'idle'",
        "send-mode",
        "rejected",
    );
    assert!(wrong.contains("wrong token"), "{wrong}");
    std::thread::sleep(Duration::from_millis(1100));
    let tilted = browser.command(
        &format!(
            "document.getElementById('token').value = '{}'; document.getElementById('cmd-pitch').value = '25'",
            run.token
        ),
        "send-target",
        "rejected",
    );
    assert!(
        tilted.contains("pitch 25.0° beyond the ±20.0° tilt limit"),
        "{tilted}"
    );
    assert_eq!(
        browser.text("mode"),
        (ControllerMode::RateDamping as u32).to_string(),
        "a rejected command changed the mode"
    );

    // Closing and reopening the page reconnects.
    browser.open("about:blank");
    std::thread::sleep(Duration::from_secs(1));
    browser.open(&page);
    let reopened = wait_for(
        "an estimate after reopening",
        Duration::from_secs(20),
        || browser.estimate().filter(|(t, _)| *t > second.0),
    );
    assert_eq!(
        browser.eval("[...document.querySelectorAll('#health tbody tr')].filter((r) => r.dataset.stale === 'true').length"),
        0,
        "a live run's processes shown stale"
    );

    let out = run.child.wait_with_output().unwrap();
    // The run is over: the link is gone, and every process row says its state is no longer
    // known instead of staying "Running".
    let rows = wait_for("every process row stale", Duration::from_secs(10), || {
        let v = browser.eval(
            "[...document.querySelectorAll('#health tbody tr')].map((r) => [r.dataset.stale, r.cells[1].textContent])",
        );
        let rows = v.as_array()?.clone();
        (!rows.is_empty() && rows.iter().all(|r| r[0] == "true")).then_some(rows)
    });
    assert!(
        rows.iter()
            .all(|r| r[1].as_str().is_some_and(|s| s.ends_with("? (link lost)"))),
        "{rows:?}"
    );
    drop(browser);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains(&format!("ground station: http://{}/", run.addr))
            && stderr.contains(&run.token),
        "testbed run did not print the ground page's URL and token: {stderr}"
    );

    // What the page showed is what the run logged: same time, same quaternion.
    let estimates = samples::<AttitudeEstimate>(&run.log);
    for (t, q) in [first, second, reopened] {
        let logged = estimates
            .iter()
            .find(|e| e.header.time_ns == t)
            .unwrap_or_else(|| panic!("no estimate at {t} ns in the log"));
        assert_eq!(logged.quaternion, q, "at {t} ns");
    }
    // The commands and their answers are in the log; the mode changed after the command.
    let commands = samples::<GroundCommand>(&run.log);
    assert_eq!(commands.len(), 1, "{commands:?}");
    assert_eq!(commands[0].kind(), Some(GroundCommandKind::Mode));
    assert_eq!(commands[0].mode, ControllerMode::RateDamping as u32);
    let acks = samples::<GroundCommandAck>(&run.log);
    let reasons: Vec<(Option<GroundAckStatus>, u32, &str)> = acks
        .iter()
        .map(|a| (a.status(), a.decided_by, a.reason()))
        .collect();
    assert_eq!(
        reasons,
        [
            (
                Some(GroundAckStatus::Applied),
                GroundCommandAck::BY_CONTROLLER,
                "mode RateDamping"
            ),
            (
                Some(GroundAckStatus::Rejected),
                GroundCommandAck::BY_LINK,
                "wrong token"
            ),
            (
                Some(GroundAckStatus::Rejected),
                GroundCommandAck::BY_LINK,
                "pitch 25.0° beyond the ±20.0° tilt limit"
            ),
        ]
    );
    let applied_at = acks[0].header.time_ns;
    let statuses = samples::<ControllerStatus>(&run.log);
    assert!(
        statuses
            .iter()
            .filter(|s| s.header.time_ns > applied_at)
            .all(|s| s.mode() == Some(ControllerMode::RateDamping)),
        "the controller left rate damping without a command"
    );
    assert!(
        statuses
            .iter()
            .any(|s| s.header.time_ns <= applied_at
                && s.mode() == Some(ControllerMode::WheelPointing)),
        "the run did not start in wheel pointing"
    );
}

#[test]
fn an_independent_client_gets_decimated_data_and_random_input_is_counted_and_dropped() {
    let scratch = Scratch::new("ground-client");
    let mut run = start_run(scratch.path(), 40);

    // A Foxglove client asking for 2 Hz gets the estimate at about 2 Hz (the pipeline
    // publishes 10 Hz), and the attitude as a foxglove.FrameTransform.
    let (mut ws, info, channels) = foxglove_client(&run.addr, "?rate_hz=2");
    assert_eq!(info["metadata"]["viewer_rate_hz"], 2.0);
    let estimate = channel_id(&channels, "testbed/gnc/attitude_estimate") as u32;
    let tf = channel_id(&channels, "testbed/tf/estimate") as u32;
    let tf_channel = channels.iter().find(|c| c["id"] == tf).unwrap();
    assert_eq!(tf_channel["schemaName"], "foxglove.FrameTransform");
    let subscribe = json!({"op": "subscribe", "subscriptions": [
        {"id": 100, "channelId": estimate}, {"id": 101, "channelId": tf}]});
    ws.send(Message::Text(subscribe.to_string().into()))
        .unwrap();
    // Message times are the run's wall-clock start plus the sample's run-clock time.
    let start_time_ns: u64 = info["metadata"]["start_time_ns"]
        .as_str()
        .and_then(|s| s.parse().ok())
        .expect("start_time_ns in the server info");
    assert!(start_time_ns > 1_700_000_000_000_000_000, "a real epoch");
    let (t0, _) = next_message(&mut ws, 100);
    let start = Instant::now();
    let mut times = vec![t0];
    while start.elapsed() < Duration::from_secs(3) {
        let (t, e) = next_message(&mut ws, 100);
        assert_eq!(
            e["header"]["time_ns"].as_u64().map(|h| start_time_ns + h),
            Some(t)
        );
        times.push(t);
    }
    let span_s = (times[times.len() - 1] - times[0]) as f64 * 1e-9;
    let rate = (times.len() - 1) as f64 / span_s;
    assert!(
        (1.0..=3.0).contains(&rate),
        "{} estimates over {span_s} s: {rate} Hz, asked for 2",
        times.len()
    );
    let (_, transform) = next_message(&mut ws, 101);
    assert_eq!(transform["parent_frame_id"], "level");
    let w = transform["rotation"]["w"].as_f64().unwrap();
    assert!(w.abs() <= 1.0 && w.abs() > 0.9, "{transform}");

    // Random input: counted, dropped, and the link goes on.
    let bad_before = stats(&run.addr)["bad_messages"].as_u64().unwrap();
    let mut sent_bad = 0u64;
    let (mut fuzz, _, _) = foxglove_client(&run.addr, &format!("?token={}", run.token));
    let advertise = json!({"op": "advertise", "channels": [
        {"id": 1, "topic": "testbed/ground/command", "encoding": "json", "schemaName": ""}]});
    fuzz.send(Message::Text(advertise.to_string().into()))
        .unwrap();
    let mut runner = TestRunner::new(Config::default());
    let frames = prop_oneof![
        // Random binary frames (a valid client-publish opcode 1 on an unknown channel,
        // or no valid opcode at all).
        proptest::collection::vec(any::<u8>(), 0..64).prop_map(|mut b| {
            if let Some(first) = b.first_mut() {
                *first = if *first % 2 == 0 { 1 } else { 2 + *first % 200 };
            }
            if b.len() >= 5 && b[0] == 1 {
                b[1] = 9; // channel 9: never advertised
            }
            Message::Binary(b.into())
        }),
        // Text that is not JSON, or JSON of the wrong shape.
        "[^{}]{0,40}".prop_map(|s| Message::Text(s.into())),
        (any::<i64>(), "[a-z]{0,8}").prop_map(|(n, op)| Message::Text(
            json!({"op": op, "subscriptions": n, "channels": [n]})
                .to_string()
                .into()
        )),
    ];
    for _ in 0..150 {
        let frame = frames.new_tree(&mut runner).unwrap().current();
        fuzz.send(frame).unwrap();
        sent_bad += 1;
    }
    // Commands of the wrong types on the advertised channel (rate-limited ones count too).
    for payload in [
        json!({"token": 1, "id": "x", "command": []}),
        json!({"token": run.token, "id": 5, "command": "mode", "mode": 3.5}),
        json!({"token": run.token, "id": 6, "command": "target", "heading_deg": "n"}),
    ] {
        let mut frame = vec![1, 1, 0, 0, 0];
        frame.extend_from_slice(payload.to_string().as_bytes());
        fuzz.send(Message::Binary(frame.into())).unwrap();
        sent_bad += 1;
        std::thread::sleep(Duration::from_millis(1100));
    }
    fuzz.flush().unwrap();
    let bad_after = wait_for(
        "the link to count the bad messages",
        Duration::from_secs(10),
        || {
            let bad = stats(&run.addr)["bad_messages"].as_u64()?;
            (bad >= bad_before + sent_bad).then_some(bad)
        },
    );
    assert_eq!(
        bad_after - bad_before,
        sent_bad,
        "every bad message counted once"
    );

    // A huge message: counted as oversized, its sender closed with 1009 (message too big).
    let oversized_before = stats(&run.addr)["oversized"].as_u64().unwrap();
    let (mut huge, _, _) = foxglove_client(&run.addr, "");
    let _ = huge.send(Message::Text("x".repeat(1 << 20).into()));
    wait_for(
        "the oversized message counted",
        Duration::from_secs(10),
        || (stats(&run.addr)["oversized"].as_u64()? > oversized_before).then_some(()),
    );
    let (code, reason) = close_frame(&mut huge);
    assert_eq!(code, CloseCode::Size, "{reason}");
    assert_eq!(reason, "message larger than 4096 bytes");

    // The link still serves the first client.
    let (t_after, _) = next_message(&mut ws, 100);
    assert!(t_after > times[times.len() - 1]);
    drop((fuzz, huge));

    // At the end of the run the link says it is going away (1001) before it closes.
    let (code, reason) = close_frame(&mut ws);
    assert_eq!(code, CloseCode::Away, "{reason}");
    let status = run.child.wait().unwrap();
    assert!(status.success(), "the run failed: {status}");
    let _ = &mut run;
}

/// Reads `ws` until the server's close frame: its code and reason. Panics if the connection
/// ends without one.
fn close_frame(ws: &mut Ws) -> (CloseCode, String) {
    if let MaybeTlsStream::Plain(s) = ws.get_mut() {
        s.set_read_timeout(Some(Duration::from_secs(90))).unwrap();
    }
    loop {
        match ws.read() {
            Ok(Message::Close(Some(frame))) => return (frame.code, frame.reason.to_string()),
            Ok(Message::Close(None)) => panic!("a close frame without a code"),
            Ok(_) => {}
            Err(e) => panic!("the connection ended without a close frame: {e}"),
        }
    }
}

/// Runs Foxglove's own client (`tests/js/foxglove_client.mjs`) against the link at `url`; its
/// summary. Panics with the script's failures.
fn foxglove_js(url: &str, token: &str, extra: &[&str]) -> Value {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("js");
    assert!(
        dir.join("node_modules/@foxglove/ws-protocol").exists(),
        "tests/js has no node_modules: run `npm ci --prefix tests/js` (.ci/run does)"
    );
    let out = Command::new("node")
        .arg(dir.join("foxglove_client.mjs"))
        .args(["--url", url, "--token", token])
        .args(extra)
        .output()
        .expect("running node (Node 20; .ci/run checks it)");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let summary: Value = stdout
        .lines()
        .rev()
        .find_map(|l| serde_json::from_str(l).ok())
        .unwrap_or_else(|| {
            panic!(
                "no summary from the client: {stdout}\n{}",
                String::from_utf8_lossy(&out.stderr)
            )
        });
    assert!(
        out.status.success() && summary["failures"] == json!([]),
        "FoxgloveClient against {url}: {:#}",
        summary["failures"]
    );
    summary
}

/// A self-signed certificate for 127.0.0.1 and localhost in `dir`, and a run configuration
/// serving TLS with it: (config, certificate).
fn tls_config(dir: &Path) -> (PathBuf, PathBuf) {
    let pair =
        rcgen::generate_simple_self_signed(vec!["127.0.0.1".into(), "localhost".into()]).unwrap();
    let cert = dir.join("ground-cert.pem");
    let key = dir.join("ground-key.pem");
    std::fs::write(&cert, pair.cert.pem()).unwrap();
    std::fs::write(&key, pair.key_pair.serialize_pem()).unwrap();
    let config = dir.join("tls.run.toml");
    std::fs::write(
        &config,
        format!(
            "[ground]\ntls_cert = {:?}\ntls_key = {:?}\n",
            cert.display().to_string(),
            key.display().to_string()
        ),
    )
    .unwrap();
    (config, cert)
}

#[test]
fn foxgloves_own_client_commands_validates_and_tls_refuses_plain_watchers_and_old_tokens() {
    // A plain run: FoxgloveClient commands the controller, every channel validates.
    let scratch = Scratch::new("ground-foxglove");
    let plain_dir = scratch.path().join("plain");
    std::fs::create_dir_all(&plain_dir).unwrap();
    let plain = start_run(&plain_dir, 25);
    let summary = foxglove_js(&format!("ws://{}/", plain.addr), &plain.token, &[]);
    assert!(summary["validated"].as_u64().unwrap() > 50, "{summary}");
    let old_token = plain.token.clone();
    let out = plain.child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let acks = samples::<GroundCommandAck>(&plain.log);
    let watch_only = acks
        .iter()
        .find(|a| a.command_id == 3)
        .expect("the watcher's command refused in the log");
    // Longer than the 64 bytes an acknowledgement once held: it arrives whole.
    assert_eq!(
        watch_only.reason(),
        "watch-only connection: commanding needs the run's command token on the URL (?token=…)"
    );
    assert!(watch_only.reason().len() > 64);

    // A TLS run with a self-signed certificate; the earlier run's token is replayed.
    let tls_dir = scratch.path().join("tls");
    std::fs::create_dir_all(&tls_dir).unwrap();
    let (config, cert) = tls_config(&tls_dir);
    let run = start_run_with(&tls_dir, 40, Some(&config));
    let info: Value =
        serde_json::from_slice(&std::fs::read(run.log.with_extension("ground.json")).unwrap())
            .unwrap();
    assert_eq!(info["ws"], format!("wss://{}/", run.addr));
    assert_ne!(run.token, old_token, "each run has its own token");
    let cert_arg = cert.display().to_string();
    let summary = foxglove_js(
        &format!("wss://{}/", run.addr),
        &run.token,
        &[
            "--ca",
            &cert_arg,
            "--old-token",
            &old_token,
            "--seconds",
            "3",
        ],
    );
    assert_eq!(summary["old_token_refused"], 401, "{summary}");

    // A plain request to the TLS link: refused, saying why.
    let refused = http_get(&run.addr, "/");
    assert_eq!(
        refused,
        "this ground link serves https:// and wss:// only\n"
    );

    // The page over https:// (the test's self-signed certificate accepted by the browser).
    let mut browser = Browser::start_with(&["--ignore-certificate-errors"]);
    browser.open(&format!("https://{}/#token={}", run.addr, run.token));
    let first = wait_for(
        "an estimate in the page over https",
        Duration::from_secs(30),
        || browser.estimate(),
    );
    wait_for("a newer estimate over wss", Duration::from_secs(10), || {
        browser.estimate().filter(|(t, _)| *t > first.0)
    });
    let applied = browser.command(
        "document.getElementById('cmd-mode').value = 'idle'",
        "send-mode",
        "applied",
    );
    assert!(applied.contains("Idle"), "{applied}");
    drop(browser);

    let out = run.child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    // Each refusal is in the log with the peer's address.
    for what in [
        "handshake refused: a plain (not TLS) connection to the TLS link",
        "handshake refused: wrong command token",
        "ground command refused",
    ] {
        assert!(
            stderr
                .lines()
                .any(|l| l.contains(what) && l.contains("peer=127.0.0.1:")),
            "no {what:?} with the peer's address in the run's output:\n{stderr}"
        );
    }
}
