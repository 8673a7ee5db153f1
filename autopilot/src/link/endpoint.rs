//! The `--mavlink` endpoint syntax, named as pymavlink and MAVProxy name
//! connections so users need not learn a new one:
//!
//! | spec | meaning |
//! |---|---|
//! | `udp:HOST:PORT` / `udpout:HOST:PORT` | send to HOST:PORT and to every address that sends a valid frame |
//! | `udpin:HOST:PORT` | listen on HOST:PORT, answer every address that sends a valid frame |
//! | `tcp:HOST:PORT` | connect to a server, reconnecting when it goes away |
//! | `tcpin:HOST:PORT` | listen for clients (each client is a link) |
//! | `serial:DEVICE:BAUD` | a serial port (telemetry radio) |

use std::fmt;
use std::str::FromStr;

/// An endpoint and whether it is a secure link: one only the operator can
/// reach (a USB cable, a socket on the vehicle). A secure link accepts
/// SETUP_SIGNING and unsigned packets whatever `SIGN_REQUIRE` says, so a
/// lost key can be reset there; a radio or network link must not be one.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LinkEndpoint {
    pub endpoint: Endpoint,
    pub secure: bool,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Endpoint {
    UdpOut { host: String, port: u16 },
    UdpIn { host: String, port: u16 },
    TcpClient { host: String, port: u16 },
    TcpServer { host: String, port: u16 },
    Serial { device: String, baud: u32 },
}

impl fmt::Display for Endpoint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Endpoint::UdpOut { host, port } => write!(f, "udp:{host}:{port}"),
            Endpoint::UdpIn { host, port } => write!(f, "udpin:{host}:{port}"),
            Endpoint::TcpClient { host, port } => write!(f, "tcp:{host}:{port}"),
            Endpoint::TcpServer { host, port } => write!(f, "tcpin:{host}:{port}"),
            Endpoint::Serial { device, baud } => write!(f, "serial:{device}:{baud}"),
        }
    }
}

impl FromStr for Endpoint {
    type Err = String;

    fn from_str(spec: &str) -> Result<Self, Self::Err> {
        let (kind, rest) = spec
            .split_once(':')
            .ok_or_else(|| format!("endpoint {spec:?}: expected KIND:ADDRESS (udp:, udpin:, tcp:, tcpin:, serial:)"))?;
        // The last ':' separates the port/baud, so IPv6 hosts and device
        // paths with ':' in them still work.
        let (head, tail) = rest
            .rsplit_once(':')
            .ok_or_else(|| format!("endpoint {spec:?}: expected {kind}:HOST:PORT"))?;
        if head.is_empty() {
            return Err(format!("endpoint {spec:?}: empty host or device"));
        }
        let host = head.trim_start_matches('[').trim_end_matches(']').to_string();
        let port = || {
            tail.parse::<u16>()
                .map_err(|_| format!("endpoint {spec:?}: port {tail:?} is not a number 0-65535"))
        };
        match kind {
            "udp" | "udpout" => Ok(Endpoint::UdpOut { host, port: port()? }),
            "udpin" => Ok(Endpoint::UdpIn { host, port: port()? }),
            "tcp" | "tcpout" => Ok(Endpoint::TcpClient { host, port: port()? }),
            "tcpin" => Ok(Endpoint::TcpServer { host, port: port()? }),
            "serial" => {
                let baud = tail
                    .parse::<u32>()
                    .ok()
                    .filter(|b| *b > 0)
                    .ok_or_else(|| format!("endpoint {spec:?}: baud {tail:?} is not a positive number"))?;
                Ok(Endpoint::Serial {
                    device: head.to_string(),
                    baud,
                })
            }
            other => Err(format!(
                "endpoint {spec:?}: unknown kind {other:?} (udp, udpin, tcp, tcpin, serial)"
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_kind() {
        assert_eq!(
            "udp:127.0.0.1:14560".parse(),
            Ok(Endpoint::UdpOut {
                host: "127.0.0.1".into(),
                port: 14560
            })
        );
        assert_eq!(
            "udpin:0.0.0.0:14551".parse(),
            Ok(Endpoint::UdpIn {
                host: "0.0.0.0".into(),
                port: 14551
            })
        );
        assert_eq!(
            "tcp:localhost:5770".parse(),
            Ok(Endpoint::TcpClient {
                host: "localhost".into(),
                port: 5770
            })
        );
        assert_eq!(
            "tcpin:[::1]:5771".parse(),
            Ok(Endpoint::TcpServer {
                host: "::1".into(),
                port: 5771
            })
        );
        assert_eq!(
            "serial:/dev/ttyUSB0:57600".parse(),
            Ok(Endpoint::Serial {
                device: "/dev/ttyUSB0".into(),
                baud: 57600
            })
        );
    }

    #[test]
    fn rejects_bad_specs_with_a_reason() {
        for bad in [
            "",
            "udp",
            "udp:1.2.3.4",
            "udp:host:99999",
            "ftp:a:1",
            "serial:/dev/x:fast",
            "tcp::5760",
        ] {
            let err = bad.parse::<Endpoint>().unwrap_err();
            assert!(err.contains("endpoint"), "{bad}: {err}");
        }
    }
}
