//! The ground link's HTTP side: the embedded page, a connection's byte stream (plain or TLS),
//! and reading a request head and answering one.

use std::collections::HashMap;
use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

/// How long a viewer thread waits for input before it looks at its queue again.
pub(super) const POLL: Duration = Duration::from_millis(20);
/// How long a connection being closed gets to read the close frame (and answer it) before its
/// socket is closed: closing a socket with unread input resets it, and the peer may then never
/// see the close frame.
pub(super) const LINGER: Duration = Duration::from_secs(1);

/// The ground page, embedded: no internet and no files needed at run time.
pub(super) const PAGE: &[(&str, &str, &str)] = &[
    (
        "/",
        "text/html; charset=utf-8",
        include_str!("../../ground-page/index.html"),
    ),
    (
        "/app.js",
        "text/javascript; charset=utf-8",
        include_str!("../../ground-page/app.js"),
    ),
    (
        "/style.css",
        "text/css; charset=utf-8",
        include_str!("../../ground-page/style.css"),
    ),
    // uPlot 1.6.32 (MIT), from npm's `uplot` package, unmodified (tests/js checks it).
    (
        "/uPlot.iife.min.js",
        "text/javascript; charset=utf-8",
        include_str!("../../ground-page/vendor/uPlot.iife.min.js"),
    ),
    (
        "/uPlot.min.css",
        "text/css; charset=utf-8",
        include_str!("../../ground-page/vendor/uPlot.min.css"),
    ),
];

/// Largest HTTP request head read, bytes.
pub(super) const MAX_REQUEST_HEAD: usize = 8192;

/// A connection's byte stream: plain TCP, or TLS over it.
pub enum Conn {
    Plain(TcpStream),
    Tls(Box<rustls::StreamOwned<rustls::ServerConnection, TcpStream>>),
}

impl Conn {
    pub(super) fn tcp(&self) -> &TcpStream {
        match self {
            Self::Plain(s) => s,
            Self::Tls(s) => &s.sock,
        }
    }

    /// Ends the connection cleanly: TLS's close_notify, then no more writes.
    fn finish(&mut self) {
        if let Self::Tls(s) = self {
            s.conn.send_close_notify();
            let _ = s.flush();
        }
        let _ = self.tcp().shutdown(std::net::Shutdown::Write);
    }

    /// Closes the connection without a reset: no more writes, then what the peer still sends
    /// read and dropped for up to [`LINGER`] (until it closes its side).
    pub(super) fn linger(&mut self) {
        self.finish();
        let start = Instant::now();
        let _ = self.tcp().set_read_timeout(Some(POLL));
        let mut sink = [0u8; 4096];
        while start.elapsed() < LINGER {
            match self.tcp().read(&mut sink) {
                Ok(0) => break,
                Ok(_) => {}
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
                Err(_) => break,
            }
        }
    }
}

impl Read for Conn {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        match self {
            Self::Plain(s) => s.read(buf),
            Self::Tls(s) => s.read(buf),
        }
    }
}

impl Write for Conn {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self {
            Self::Plain(s) => s.write(buf),
            Self::Tls(s) => s.write(buf),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match self {
            Self::Plain(s) => s.flush(),
            Self::Tls(s) => s.flush(),
        }
    }
}

/// A parsed HTTP request head.
pub(super) struct Request {
    pub(super) path: String,
    pub(super) query: String,
    pub(super) headers: HashMap<String, String>,
    /// Bytes read past the head (a client's first WebSocket frame).
    pub(super) rest: Vec<u8>,
}

impl Request {
    /// The value of `key` in the query, percent-decoded (`None` if absent or not UTF-8).
    pub(super) fn query_value(&self, key: &str) -> Option<String> {
        let raw = self
            .query
            .split('&')
            .find_map(|kv| kv.strip_prefix(key)?.strip_prefix('='))?;
        percent_decode(raw)
    }
}

/// `%XX` escapes decoded (what `encodeURIComponent` makes).
fn percent_decode(raw: &str) -> Option<String> {
    let bytes = raw.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = raw.get(i + 1..i + 3)?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

pub(super) fn read_request(stream: &mut Conn) -> std::io::Result<Option<Request>> {
    let mut buf = Vec::with_capacity(1024);
    let mut chunk = [0u8; 1024];
    let end = loop {
        if let Some(i) = buf.windows(4).position(|w| w == b"\r\n\r\n") {
            break i;
        }
        if buf.len() > MAX_REQUEST_HEAD {
            return Ok(None);
        }
        let n = stream.read(&mut chunk)?;
        if n == 0 {
            return Ok(None);
        }
        buf.extend_from_slice(&chunk[..n]);
    };
    let head = String::from_utf8_lossy(&buf[..end]).into_owned();
    let rest = buf[end + 4..].to_vec();
    let mut lines = head.split("\r\n");
    let mut first = lines.next().unwrap_or_default().split(' ');
    if first.next() != Some("GET") {
        return Ok(None);
    }
    let target = first.next().unwrap_or("/");
    let (path, query) = target.split_once('?').unwrap_or((target, ""));
    let headers = lines
        .filter_map(|l| l.split_once(':'))
        .map(|(k, v)| (k.trim().to_ascii_lowercase(), v.trim().to_owned()))
        .collect();
    Ok(Some(Request {
        path: path.to_owned(),
        query: query.to_owned(),
        headers,
        rest,
    }))
}

pub(super) fn respond(
    stream: &mut Conn,
    status: &str,
    kind: &str,
    body: &[u8],
) -> std::io::Result<()> {
    write!(
        stream,
        "HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n",
        body.len()
    )?;
    stream.write_all(body)?;
    stream.flush()?;
    stream.finish();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::PAGE;
    use std::path::Path;

    /// The page's uPlot is npm's `uplot` 1.6.32 byte for byte (tests/js pins that version; run
    /// `npm ci --prefix tests/js`, as .ci/run does, to check it; skipped outside CI without it).
    #[test]
    fn the_served_uplot_is_the_npm_package() {
        let dist =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/js/node_modules/uplot/dist");
        if !dist.is_dir() {
            assert!(
                std::env::var_os("CI").is_none(),
                "under CI, tests/js/node_modules is needed (run `npm ci` in tests/js)"
            );
            eprintln!("skipped: needs `npm ci` in tests/js");
            return;
        }
        for (path, file) in [
            ("/uPlot.iife.min.js", "uPlot.iife.min.js"),
            ("/uPlot.min.css", "uPlot.min.css"),
        ] {
            let served = PAGE.iter().find(|(p, _, _)| *p == path).expect("served");
            let npm = std::fs::read_to_string(dist.join(file)).expect("npm's file");
            assert!(
                served.2 == npm,
                "{path} differs from npm's uplot/dist/{file}"
            );
        }
    }
}
