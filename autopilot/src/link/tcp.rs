//! TCP links: a server that accepts any number of clients (each its own
//! link), and a client that reconnects when its server goes away.

use std::time::Duration;

use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::mpsc;

use super::frame::StreamFramer;
use super::hub::{HubEvent, LinkIds, LinkRole, PeerPolicy, open_link, write_loop};
use super::pacing::LinkPace;

/// Accepts clients until the runtime stops.
pub(super) async fn serve(listener: TcpListener, role: LinkRole, ids: LinkIds, hub: mpsc::Sender<HubEvent>) {
    loop {
        match listener.accept().await {
            Ok((stream, peer)) => {
                let _ = stream.set_nodelay(true);
                let name = format!("tcp client {peer}");
                tokio::spawn(run_stream(stream, ids.next(), role, name, hub.clone()));
            }
            Err(e) => {
                // Out of file descriptors and the like: back off, keep serving.
                tracing::warn!("tcp accept: {e}");
                tokio::time::sleep(Duration::from_millis(100)).await;
            }
        }
    }
}

/// Connects to `addr`, and again after every disconnect.
pub(super) async fn connect_forever(addr: String, role: LinkRole, ids: LinkIds, hub: mpsc::Sender<HubEvent>) {
    let mut backoff = super::reconnect_backoff();
    loop {
        match TcpStream::connect(&addr).await {
            Ok(stream) => {
                let _ = stream.set_nodelay(true);
                tracing::info!("tcp connected to {addr}");
                backoff.reset();
                run_stream(stream, ids.next(), role, format!("tcp to {addr}"), hub.clone()).await;
                tracing::info!("tcp to {addr} closed; reconnecting");
            }
            Err(e) => tracing::debug!("tcp connect {addr}: {e}"),
        }
        tokio::time::sleep(backoff.next_delay()).await;
    }
}

/// Kernel send buffer of a TCP link. Small on purpose: telemetry queued in a
/// multi-megabyte buffer is stale by the time a slow client reads it; with
/// this, a client that stops reading fills its own queue in the hub (which
/// then drops and counts) within seconds.
const SEND_BUFFER_BYTES: usize = 32 * 1024;

async fn run_stream(
    stream: TcpStream,
    link: crate::vehicle::LinkId,
    role: LinkRole,
    name: String,
    hub: mpsc::Sender<HubEvent>,
) {
    if let Err(e) = socket2::SockRef::from(&stream).set_send_buffer_size(SEND_BUFFER_BYTES) {
        tracing::debug!("{name}: SO_SNDBUF: {e}");
    }
    let (read, write) = stream.into_split();
    run_link(read, write, link, role, name, hub).await;
}

/// One byte-stream link: registers with the hub, writes what the hub queues
/// for it, reads and frames what arrives, unregisters when either side ends.
pub(super) async fn run_link<R, W>(
    mut read: R,
    write: W,
    link: crate::vehicle::LinkId,
    role: LinkRole,
    name: String,
    hub: mpsc::Sender<HubEvent>,
) where
    R: AsyncRead + Unpin,
    W: AsyncWrite + Unpin + Send + 'static,
{
    let (opened, rx, queued) = open_link(link, role, PeerPolicy::Connection, name.clone(), LinkPace::Network);
    if hub.send(opened).await.is_err() {
        return;
    }
    let mut writer = tokio::spawn(write_loop(write, rx, queued));
    let mut framer = StreamFramer::new();
    let mut buf = vec![0u8; 4096];
    loop {
        tokio::select! {
            read = read.read(&mut buf) => match read {
                Ok(0) | Err(_) => break,
                Ok(n) => {
                    let mut frames = Vec::new();
                    framer.push(&buf[..n], |f| frames.push(f));
                    for frame in frames {
                        if hub.send(HubEvent::Frame { link, frame, from: None }).await.is_err() {
                            return;
                        }
                    }
                    let _ = hub.try_send(HubEvent::Stats { link, stats: framer.stats() });
                }
            },
            // The writer ends when the peer stops accepting bytes for good.
            _ = &mut writer => break,
        }
    }
    writer.abort();
    tracing::info!("{name}: closed");
    let _ = hub.send(HubEvent::Closed { link }).await;
}
