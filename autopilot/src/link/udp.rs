//! A UDP link: one socket, one link, any number of ground stations. It
//! sends to its configured destination (the GCS port, as ArduPilot SITL
//! sends to 14550) and to every address the hub has admitted as a peer
//! (see [`super::peers`]): only a valid MAVLink frame can make one, so a
//! stranger's datagrams never divert the telemetry.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use tokio::net::UdpSocket;
use tokio::sync::mpsc;

use super::frame::{FrameStats, frame_datagram};
use super::hub::{HubEvent, LinkRole, PeerPolicy};
use crate::vehicle::LinkId;

/// Receive counters go to the hub at most this often while only garbage
/// arrives: a flood of datagrams must not become a flood of hub events.
const STATS_PERIOD: Duration = Duration::from_millis(200);

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
            peers: PeerPolicy::Addresses { fixed: default_peer },
            name: name.clone(),
            tx,
        })
        .await
        .is_err()
    {
        return;
    }
    let mut stats = FrameStats::default();
    let mut stats_sent = Instant::now();
    let mut buf = vec![0u8; 65536];
    loop {
        tokio::select! {
            received = socket.recv_from(&mut buf) => match received {
                Ok((n, from)) => {
                    let mut frames = Vec::new();
                    frame_datagram(&buf[..n], &mut stats, |f| frames.push(f));
                    let framed = !frames.is_empty();
                    for frame in frames {
                        if hub.send(HubEvent::Frame { link, frame, from: Some(from) }).await.is_err() {
                            return;
                        }
                    }
                    if framed || stats_sent.elapsed() >= STATS_PERIOD {
                        let _ = hub.try_send(HubEvent::Stats { link, stats });
                        stats_sent = Instant::now();
                    }
                }
                // ICMP errors from a peer that went away: keep serving.
                Err(e) => tracing::debug!("{name}: {e}"),
            },
            frame = rx.recv() => match frame {
                Some(frame) => {
                    for to in frame.to.iter() {
                        if let Err(e) = socket.send_to(&frame.bytes, to).await {
                            tracing::debug!("{name}: send to {to}: {e}");
                        }
                    }
                }
                None => return,
            },
        }
    }
}
