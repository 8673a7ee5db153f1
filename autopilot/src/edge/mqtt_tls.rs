//! TLS for the VDA 5050 MQTT client (`mqtts://`): rustls with the ring
//! provider, the broker checked against a CA file (or the system's trust
//! store when none is given), and optionally a client certificate for
//! brokers that require one. The files are read and checked when the
//! configuration is, so a wrong file is an error at start-up rather than an
//! endless reconnect.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use rustls::ClientConfig;
use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, PrivateKeyDer};

/// Where the TLS material is (PEM files).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TlsFiles {
    /// The CA that signed the broker's certificate; `None`: the system's
    /// trust store.
    pub ca_file: Option<PathBuf>,
    /// This vehicle's certificate (chain) and private key.
    pub client_auth: Option<(PathBuf, PathBuf)>,
}

/// Which of the files a problem is in, and what it is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TlsError {
    pub file: TlsFile,
    pub message: String,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TlsFile {
    Ca,
    ClientCert,
    ClientKey,
}

impl std::fmt::Display for TlsError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

fn read(file: TlsFile, path: &Path) -> Result<Vec<u8>, TlsError> {
    std::fs::read(path).map_err(|e| TlsError {
        file,
        message: format!("cannot read {}: {e}", path.display()),
    })
}

fn certificates(file: TlsFile, path: &Path) -> Result<Vec<CertificateDer<'static>>, TlsError> {
    let bytes = read(file, path)?;
    let bad = |message: String| TlsError { file, message };
    let certs = CertificateDer::pem_slice_iter(&bytes)
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| bad(format!("{}: not a PEM certificate file: {e}", path.display())))?;
    if certs.is_empty() {
        return Err(bad(format!(
            "{}: no certificate in it (expected PEM, -----BEGIN CERTIFICATE-----)",
            path.display()
        )));
    }
    Ok(certs)
}

fn private_key(path: &Path) -> Result<PrivateKeyDer<'static>, TlsError> {
    let bytes = read(TlsFile::ClientKey, path)?;
    PrivateKeyDer::from_pem_slice(&bytes).map_err(|e| TlsError {
        file: TlsFile::ClientKey,
        message: format!(
            "{}: no private key in it (PEM PKCS#8, PKCS#1 or SEC1): {e}",
            path.display()
        ),
    })
}

fn roots(ca_file: Option<&Path>) -> Result<rustls::RootCertStore, TlsError> {
    let mut store = rustls::RootCertStore::empty();
    let bad = |message: String| TlsError {
        file: TlsFile::Ca,
        message,
    };
    match ca_file {
        Some(path) => {
            for cert in certificates(TlsFile::Ca, path)? {
                store
                    .add(cert)
                    .map_err(|e| bad(format!("{}: not a usable CA certificate: {e}", path.display())))?;
            }
        }
        None => {
            let found = rustls_native_certs::load_native_certs();
            let (added, _) = store.add_parsable_certificates(found.certs);
            if added == 0 {
                return Err(bad(
                    "no CA file given and no certificate in the system's trust store: give the broker's CA".into(),
                ));
            }
        }
    }
    Ok(store)
}

/// The client's TLS configuration from the files.
pub fn client_config(files: &TlsFiles) -> Result<Arc<ClientConfig>, TlsError> {
    let provider = Arc::new(rustls::crypto::ring::default_provider());
    let builder = ClientConfig::builder_with_provider(provider)
        .with_safe_default_protocol_versions()
        .map_err(|e| TlsError {
            file: TlsFile::Ca,
            message: format!("TLS set-up: {e}"),
        })?
        .with_root_certificates(roots(files.ca_file.as_deref())?);
    let config = match &files.client_auth {
        Some((cert, key)) => {
            let chain = certificates(TlsFile::ClientCert, cert)?;
            builder
                .with_client_auth_cert(chain, private_key(key)?)
                .map_err(|e| TlsError {
                    file: TlsFile::ClientKey,
                    message: format!("{} does not go with {}: {e}", key.display(), cert.display()),
                })?
        }
        None => builder.with_no_client_auth(),
    };
    Ok(Arc::new(config))
}

#[cfg(test)]
mod tests {
    use std::io::Write;

    use super::*;

    fn file_with(text: &str) -> tempfile::NamedTempFile {
        let mut file = tempfile::NamedTempFile::new().expect("temp file");
        file.write_all(text.as_bytes()).expect("write");
        file
    }

    #[test]
    fn files_that_are_not_pem_certificates_or_keys_are_refused_by_name() {
        let junk = file_with("not a certificate\n");
        let files = TlsFiles {
            ca_file: Some(junk.path().to_path_buf()),
            client_auth: None,
        };
        let e = client_config(&files).unwrap_err();
        assert_eq!(e.file, TlsFile::Ca);
        assert!(e.message.contains("no certificate"), "{e}");

        let missing = TlsFiles {
            ca_file: Some("/nonexistent/ca.pem".into()),
            client_auth: None,
        };
        let e = client_config(&missing).unwrap_err();
        assert!(e.message.contains("cannot read /nonexistent/ca.pem"), "{e}");

        let broken = file_with("-----BEGIN CERTIFICATE-----\n!!!\n-----END CERTIFICATE-----\n");
        let files = TlsFiles {
            ca_file: Some(broken.path().to_path_buf()),
            client_auth: None,
        };
        assert_eq!(client_config(&files).unwrap_err().file, TlsFile::Ca);
    }
}
