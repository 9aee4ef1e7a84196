//! The ground link's TLS (`https://` and `wss://` on the link's one port): the certificate
//! chain and private key of `ground.tls_cert` / `ground.tls_key` (PEM), read with rustls's own
//! PEM parser, served with rustls on the `ring` provider.

use rustls::pki_types::pem::PemObject as _;
use rustls::pki_types::{CertificateDer, PrivateKeyDer};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Why the link's TLS configuration could not be made. Each names the file or what is wrong.
#[derive(Debug, thiserror::Error)]
pub enum TlsError {
    #[error("ground.tls_cert {path}: {source}")]
    Cert {
        path: PathBuf,
        source: rustls::pki_types::pem::Error,
    },
    #[error("ground.tls_cert {0}: no certificate in it (PEM \"BEGIN CERTIFICATE\")")]
    NoCert(PathBuf),
    #[error("ground.tls_key {path}: {source} (a PEM private key: PKCS#8, PKCS#1 RSA or SEC1 EC)")]
    Key {
        path: PathBuf,
        source: rustls::pki_types::pem::Error,
    },
    #[error("ground.tls_cert / ground.tls_key: {0}")]
    Rustls(#[from] rustls::Error),
}

/// The server configuration of `cert` (the chain, leaf first) and `key`.
pub fn server_config(cert: &Path, key: &Path) -> Result<Arc<rustls::ServerConfig>, TlsError> {
    let chain = CertificateDer::pem_file_iter(cert)
        .and_then(|certs| certs.collect::<Result<Vec<_>, _>>())
        .map_err(|source| TlsError::Cert {
            path: cert.to_owned(),
            source,
        })?;
    if chain.is_empty() {
        return Err(TlsError::NoCert(cert.to_owned()));
    }
    let key = PrivateKeyDer::from_pem_file(key).map_err(|source| TlsError::Key {
        path: key.to_owned(),
        source,
    })?;
    let provider = Arc::new(rustls::crypto::ring::default_provider());
    // `with_single_cert` checks that the key matches the leaf certificate.
    let config = rustls::ServerConfig::builder_with_provider(provider)
        .with_safe_default_protocol_versions()?
        .with_no_client_auth()
        .with_single_cert(chain, key)?;
    Ok(Arc::new(config))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        path
    }

    #[test]
    fn a_self_signed_pair_loads_and_bad_files_are_named() {
        let dir = std::env::temp_dir().join(format!("tls-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let pair = rcgen::generate_simple_self_signed(vec!["localhost".into()]).unwrap();
        let cert = write(&dir, "cert.pem", &pair.cert.pem());
        let key = write(&dir, "key.pem", &pair.key_pair.serialize_pem());
        server_config(&cert, &key).expect("a matching pair");

        let missing = dir.join("missing.pem");
        let e = server_config(&missing, &key).unwrap_err();
        assert!(e.to_string().starts_with("ground.tls_cert "), "{e}");
        assert!(e.to_string().contains("missing.pem"), "{e}");
        let e = server_config(&key, &key).unwrap_err();
        assert!(matches!(e, TlsError::NoCert(_)), "{e}");
        let e = server_config(&cert, &cert).unwrap_err();
        assert!(e.to_string().starts_with("ground.tls_key "), "{e}");
        // A key of another certificate.
        let other = rcgen::generate_simple_self_signed(vec!["localhost".into()]).unwrap();
        let other_key = write(&dir, "other.pem", &other.key_pair.serialize_pem());
        let e = server_config(&cert, &other_key).unwrap_err();
        assert!(matches!(e, TlsError::Rustls(_)), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
