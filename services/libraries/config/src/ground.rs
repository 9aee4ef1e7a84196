//! `[ground]`: the ground link's server and the limits of the commands it accepts, and the
//! run's command token.

use serde::{Deserialize, Serialize};

/// Environment variable with the run's command token (`testbed run` makes one per run when
/// `ground.token` is not set; the ground link makes its own if neither is there).
pub const ENV_GROUND_TOKEN: &str = "TESTBED_GROUND_TOKEN";

/// The ground link: where it listens, what it sends each viewer, what commands it accepts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GroundConfig {
    /// Address the ground link listens on: the ground page (HTTP) and the Foxglove WebSocket
    /// protocol share one port. Default loopback only; `0.0.0.0` serves the lab network.
    pub bind: String,
    /// TCP port (0: any free port, printed at start and written to `<log>.ground.json`).
    /// Default 8765, the Foxglove WebSocket protocol's usual port. If it is taken (another
    /// run), the link warns and takes a free port instead.
    pub port: u16,
    /// Samples per second per topic sent to a viewer that asks for no rate (`?rate_hz=` on
    /// the WebSocket URL), Hz. 10 Hz: the control rate (assumed; the paper's link is 54 Mbit/s
    /// Wi-Fi, far above what one viewer needs at this rate).
    pub viewer_rate_hz: f64,
    /// Highest rate a viewer may ask for, Hz.
    pub max_viewer_rate_hz: f64,
    /// Viewers connected at once; more are refused (HTTP 503).
    pub max_viewers: usize,
    /// Messages queued per viewer; what does not fit is dropped and counted (a slow viewer
    /// never holds up the pipeline).
    pub viewer_queue: usize,
    /// Largest message a viewer may send, bytes; larger ones are counted and dropped.
    pub max_message_bytes: usize,
    /// Commands a viewer may send in a burst (token bucket).
    pub command_burst: u32,
    /// Sustained commands per second per viewer (token bucket refill), Hz.
    pub command_rate_hz: f64,
    /// Largest target tilt (pitch or roll) a command may ask for, degrees. 20°: the air
    /// bearing's ±30° tilt stop (`model.platform.tilt_limit_deg`, paper) less a 10° margin
    /// (assumed).
    pub max_target_tilt_deg: f64,
    /// The command token; `None`: one per run (see [`ENV_GROUND_TOKEN`]). A configured token
    /// is a standing password: the same in every run, it does not expire with one.
    pub token: Option<String>,
    /// TLS: the certificate chain the link serves `https://` and `wss://` with, PEM (leaf
    /// first), e.g. issued by the lab's CA for the station's address; with
    /// [`tls_key`](Self::tls_key). `None` (default): plain `http://` and `ws://`, for loopback
    /// simulation runs. With TLS the link refuses plain connections.
    pub tls_cert: Option<std::path::PathBuf>,
    /// TLS: the private key of [`tls_cert`](Self::tls_cert), PEM (PKCS#8, PKCS#1 or SEC1).
    pub tls_key: Option<std::path::PathBuf>,
}

/// 128 random bits from the OS, hex: a run's ground command token.
pub fn random_token() -> std::io::Result<String> {
    use std::io::Read as _;
    let mut bytes = [0u8; 16];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut bytes))
        .map_err(|e| std::io::Error::new(e.kind(), format!("reading /dev/urandom: {e}")))?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

impl Default for GroundConfig {
    fn default() -> Self {
        Self {
            bind: "127.0.0.1".into(),
            port: 8765,
            viewer_rate_hz: 10.0,
            max_viewer_rate_hz: 50.0,
            max_viewers: 16,
            viewer_queue: 256,
            max_message_bytes: 4096,
            command_burst: 3,
            command_rate_hz: 1.0,
            max_target_tilt_deg: 20.0,
            token: None,
            tls_cert: None,
            tls_key: None,
        }
    }
}

impl GroundConfig {
    /// The first invalid value: key, value, reason.
    pub fn validate(&self, tilt_limit_deg: f64) -> Result<(), (String, String, String)> {
        let bad = |key: &str, value: String, reason: &str| {
            Err((format!("ground.{key}"), value, reason.to_string()))
        };
        if self.bind.parse::<std::net::IpAddr>().is_err() {
            return bad("bind", self.bind.clone(), "must be an IP address");
        }
        let rate_ok = |r: f64| r.is_finite() && r > 0.0;
        if !rate_ok(self.viewer_rate_hz) || self.viewer_rate_hz > self.max_viewer_rate_hz {
            return bad(
                "viewer_rate_hz",
                self.viewer_rate_hz.to_string(),
                "must be > 0 and at most ground.max_viewer_rate_hz",
            );
        }
        if !rate_ok(self.max_viewer_rate_hz) {
            return bad(
                "max_viewer_rate_hz",
                self.max_viewer_rate_hz.to_string(),
                "must be > 0",
            );
        }
        if self.max_viewers == 0 || self.viewer_queue == 0 {
            return bad(
                "max_viewers / viewer_queue",
                format!("{} / {}", self.max_viewers, self.viewer_queue),
                "must be >= 1",
            );
        }
        if !(64..=1 << 20).contains(&self.max_message_bytes) {
            return bad(
                "max_message_bytes",
                self.max_message_bytes.to_string(),
                "must be 64 to 1048576",
            );
        }
        if self.command_burst == 0 || !rate_ok(self.command_rate_hz) {
            return bad(
                "command_burst / command_rate_hz",
                format!("{} / {}", self.command_burst, self.command_rate_hz),
                "must be >= 1 and > 0",
            );
        }
        if !(self.max_target_tilt_deg.is_finite()
            && self.max_target_tilt_deg >= 0.0
            && self.max_target_tilt_deg < tilt_limit_deg)
        {
            return bad(
                "max_target_tilt_deg",
                self.max_target_tilt_deg.to_string(),
                "must be >= 0 and below model.platform.tilt_limit_deg",
            );
        }
        if let Some(token) = &self.token
            && (token.len() < 16 || !token.chars().all(|c| c.is_ascii_graphic()))
        {
            return bad(
                "token",
                "(hidden)".into(),
                "must be at least 16 printable ASCII characters",
            );
        }
        if self.tls_cert.is_some() != self.tls_key.is_some() {
            return bad(
                "tls_cert / tls_key",
                format!(
                    "{} / {}",
                    self.tls_cert
                        .as_ref()
                        .map_or("(unset)".into(), |p| p.display().to_string()),
                    self.tls_key
                        .as_ref()
                        .map_or("(unset)".into(), |p| p.display().to_string())
                ),
                "set both (certificate and its key) or neither",
            );
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tls_needs_both_the_certificate_and_its_key() {
        let mut g = GroundConfig::default();
        assert!(g.validate(30.0).is_ok(), "plain by default");
        g.tls_cert = Some("/etc/testbed/ground.crt".into());
        let (key, value, reason) = g.validate(30.0).unwrap_err();
        assert_eq!(key, "ground.tls_cert / tls_key");
        assert_eq!(value, "/etc/testbed/ground.crt / (unset)");
        assert!(reason.contains("both"), "{reason}");
        g.tls_key = Some("/etc/testbed/ground.key".into());
        assert!(g.validate(30.0).is_ok());
    }
}
