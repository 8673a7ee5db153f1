//! A UDP link: one socket, one link. It sends to a default peer (the GCS
//! port, as ArduPilot SITL sends to 14550) and, once anyone talks to it,
//! answers whatever address and port that was.

use std::net::SocketAddr;

use tokio::net::UdpSocket;
use tokio::sync::mpsc;

use super::frame::{FrameStats, frame_datagram};
use super::hub::{HubEvent, LinkRole};
use crate::vehicle::LinkId;

pub(super) async fn run(
    socket: UdpSocket,
    default_peer: Option<SocketAddr>,
    link: LinkId,
    role: LinkRole,
    name: String,
    hub: mpsc::Sender<HubEvent>,
) {
    let (tx, mut rx) = mpsc::channel(super::hub::LINK_QUEUE);
    if hub
        .send(HubEvent::Opened {
            link,
            role,
            name: name.clone(),
            tx,
        })
        .await
        .is_err()
    {
        return;
    }
    let mut peer = default_peer;
    let mut stats = FrameStats::default();
    let mut buf = vec![0u8; 65536];
    loop {
        tokio::select! {
            received = socket.recv_from(&mut buf) => match received {
                Ok((n, from)) => {
                    if peer != Some(from) {
                        tracing::info!("{name}: talking to {from}");
                        peer = Some(from);
                    }
                    let mut frames = Vec::new();
                    frame_datagram(&buf[..n], &mut stats, |f| frames.push(f));
                    for frame in frames {
                        if hub.send(HubEvent::Frame { link, frame }).await.is_err() {
                            return;
                        }
                    }
                    let _ = hub.try_send(HubEvent::Stats { link, stats });
                }
                // ICMP errors from a peer that went away: keep serving.
                Err(e) => tracing::debug!("{name}: {e}"),
            },
            frame = rx.recv() => match frame {
                Some(bytes) => {
                    if let Some(to) = peer
                        && let Err(e) = socket.send_to(&bytes, to).await
                    {
                        tracing::debug!("{name}: send to {to}: {e}");
                    }
                }
                None => return,
            },
        }
    }
}
