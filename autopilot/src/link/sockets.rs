//! The link layer's sockets, bound by the caller before the hub starts: a
//! busy port is an error at start, not later, the addresses actually bound
//! (port 0 picks one) are known before anything runs, and tests bind their
//! own sockets on port 0.
//!
//! Stream slots (`SRn_*`, the `SIGN_REQUIRE` bits): the TCP server is slot
//! 0, the UDP link slot 1, the extra endpoints 2, 3, then 3 again.

use std::future::Future;
use std::io;
use std::net::{SocketAddr, TcpListener, ToSocketAddrs, UdpSocket};
use std::path::PathBuf;
use std::pin::Pin;

use tokio::sync::mpsc;

use super::endpoint::{Endpoint, LinkEndpoint};
use super::hub::LinkRole;
use super::tlog::{self, TlogRecord};

/// Which links to open, as the command line and the configuration file
/// name them.
#[derive(Clone, Debug, Default)]
pub struct LinkEndpoints {
    /// The TCP server (stream slot 0): `host:port`, port 0 for any.
    pub tcp_server: Option<String>,
    /// The UDP link (stream slot 1): where to send until someone answers.
    pub udp_out: Option<String>,
    /// Extra endpoints (stream slots 2, 3, then 3 again), some secure.
    pub extra: Vec<LinkEndpoint>,
    /// Where to record every frame (.tlog).
    pub tlog: Option<PathBuf>,
}

/// Addresses actually bound (ports may have been 0).
#[derive(Clone, Debug, Default)]
pub struct BoundAddresses {
    pub tcp: Option<SocketAddr>,
    pub udp_local: Option<SocketAddr>,
    /// The secure endpoints, in endpoint syntax with the port a listener
    /// actually bound (`tcpin:127.0.0.1:40123`).
    pub secure: Vec<String>,
}

/// One link's way to the outside, bound where binding applies.
pub(super) enum LinkSocket {
    TcpServer(TcpListener),
    Udp {
        socket: UdpSocket,
        /// The configured destination, sent to before anyone speaks.
        fixed: Option<SocketAddr>,
        name: String,
    },
    /// Connected (and reconnected) once running.
    TcpClient(String),
    /// Opened (and reopened) by its own thread once running.
    Serial {
        device: String,
        baud: u32,
    },
}

pub(super) type TlogTask = Pin<Box<dyn Future<Output = ()> + Send>>;

/// Every link's socket and the tlog file, ready for the hub.
#[derive(Default)]
pub struct LinkSockets {
    pub(super) links: Vec<(LinkSocket, LinkRole)>,
    pub(super) tlog: Option<(mpsc::Sender<TlogRecord>, TlogTask)>,
    pub bound: BoundAddresses,
}

impl LinkSockets {
    /// Binds every endpoint and creates the tlog file.
    pub fn bind(endpoints: &LinkEndpoints) -> io::Result<LinkSockets> {
        let mut sockets = LinkSockets::default();
        if let Some(spec) = &endpoints.tcp_server {
            sockets.tcp_server(TcpListener::bind(resolve(spec)?)?)?;
        }
        if let Some(spec) = &endpoints.udp_out {
            let peer = resolve(spec)?;
            sockets.udp(UdpSocket::bind(unspecified_like(peer))?, Some(peer))?;
        }
        for (i, endpoint) in endpoints.extra.iter().enumerate() {
            let role = LinkRole {
                slot: (2 + i).min(3) as u8,
                secure: endpoint.secure,
            };
            sockets.extra(endpoint, role)?;
        }
        if let Some(path) = &endpoints.tlog {
            let (tx, task) =
                tlog::open(path).map_err(|e| io::Error::new(e.kind(), format!("tlog {}: {e}", path.display())))?;
            sockets.tlog = Some((tx, Box::pin(task)));
        }
        Ok(sockets)
    }

    /// The TCP server (stream slot 0), bound by the caller.
    pub fn tcp_server(&mut self, listener: TcpListener) -> io::Result<()> {
        self.bound.tcp = Some(listener.local_addr()?);
        let role = LinkRole { slot: 0, secure: false };
        self.links.push((LinkSocket::TcpServer(listener), role));
        Ok(())
    }

    /// The UDP link (stream slot 1), bound by the caller; `to`: where it
    /// sends until someone answers.
    pub fn udp(&mut self, socket: UdpSocket, to: Option<SocketAddr>) -> io::Result<()> {
        let local = socket.local_addr()?;
        self.bound.udp_local = Some(local);
        let name = match to {
            Some(peer) => format!("udp to {peer}"),
            None => format!("udp on {local}"),
        };
        let role = LinkRole { slot: 1, secure: false };
        let fixed = to;
        self.links.push((LinkSocket::Udp { socket, fixed, name }, role));
        Ok(())
    }

    fn extra(&mut self, link: &LinkEndpoint, role: LinkRole) -> io::Result<()> {
        let endpoint = &link.endpoint;
        let mut shown = endpoint.to_string();
        let socket = match endpoint {
            Endpoint::UdpOut { host, port } => {
                let peer = resolve(&format!("{host}:{port}"))?;
                LinkSocket::Udp {
                    socket: UdpSocket::bind(unspecified_like(peer))?,
                    fixed: Some(peer),
                    name: shown.clone(),
                }
            }
            Endpoint::UdpIn { host, port } => {
                let socket = UdpSocket::bind(resolve(&format!("{host}:{port}"))?)?;
                let name = shown.clone();
                shown = format!("udpin:{}", socket.local_addr()?);
                LinkSocket::Udp {
                    socket,
                    fixed: None,
                    name,
                }
            }
            Endpoint::TcpServer { host, port } => {
                let listener = TcpListener::bind(resolve(&format!("{host}:{port}"))?)?;
                shown = format!("tcpin:{}", listener.local_addr()?);
                LinkSocket::TcpServer(listener)
            }
            Endpoint::TcpClient { host, port } => LinkSocket::TcpClient(format!("{host}:{port}")),
            Endpoint::Serial { device, baud } => LinkSocket::Serial {
                device: device.clone(),
                baud: *baud,
            },
        };
        if link.secure {
            self.bound.secure.push(shown);
        }
        self.links.push((socket, role));
        Ok(())
    }
}

/// The extra links from plain and secure endpoints: plain ones first.
pub fn extra_links(plain: &[Endpoint], secure: &[Endpoint]) -> Vec<LinkEndpoint> {
    let link = |secure: bool| {
        move |endpoint: &Endpoint| LinkEndpoint {
            endpoint: endpoint.clone(),
            secure,
        }
    };
    plain
        .iter()
        .map(link(false))
        .chain(secure.iter().map(link(true)))
        .collect()
}

fn resolve(spec: &str) -> io::Result<SocketAddr> {
    spec.to_socket_addrs()?
        .next()
        .ok_or_else(|| io::Error::new(io::ErrorKind::NotFound, format!("{spec}: no address")))
}

/// Binds loopback for a loopback peer (so nothing else on the network can
/// inject), any address otherwise.
fn unspecified_like(peer: SocketAddr) -> SocketAddr {
    match peer {
        SocketAddr::V4(a) if a.ip().is_loopback() => "127.0.0.1:0".parse().expect("literal"),
        SocketAddr::V4(_) => "0.0.0.0:0".parse().expect("literal"),
        SocketAddr::V6(a) if a.ip().is_loopback() => "[::1]:0".parse().expect("literal"),
        SocketAddr::V6(_) => "[::]:0".parse().expect("literal"),
    }
}
