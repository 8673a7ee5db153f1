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
use super::hub::{HubEvent, LinkFrame, LinkRole, PeerPolicy, open_link};
use super::pacing::LinkPace;
use crate::vehicle::LinkId;

/// Receive counters go to the hub at most this often while only garbage
/// arrives: a flood of datagrams must not become a flood of hub events.
const STATS_PERIOD: Duration = Duration::from_millis(200);
/// Frames queued together for the same addresses share a datagram up to
/// this size (an Ethernet MTU's UDP payload: no IP fragmentation). Ground
/// stations read every frame in a datagram, as ArduPilot sends them; a
/// burst of replies then costs the receiver a few datagrams, not hundreds
/// that could overflow its socket buffer.
const MAX_DATAGRAM: usize = 1472;

pub(super) async fn run(
    socket: UdpSocket,
    default_peer: Option<SocketAddr>,
    link: LinkId,
    role: LinkRole,
    name: String,
    hub: mpsc::Sender<HubEvent>,
) {
    let peers = PeerPolicy::Addresses { fixed: default_peer };
    let (opened, mut rx, queued) = open_link(link, role, peers, name.clone(), LinkPace::Network);
    if hub.send(opened).await.is_err() {
        return;
    }
    let mut stats = FrameStats::default();
    let mut stats_sent = Instant::now();
    let mut buf = vec![0u8; 65536];
    let mut datagram = Vec::with_capacity(MAX_DATAGRAM);
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
                    let mut next = Some(frame);
                    while let Some(frame) = next.take() {
                        let to = frame.to.clone();
                        next = fill_datagram(frame, &mut rx, &mut datagram);
                        for to in to.iter() {
                            if let Err(e) = socket.send_to(&datagram, to).await {
                                tracing::debug!("{name}: send to {to}: {e}");
                            }
                        }
                        queued.written(datagram.len());
                    }
                }
                None => return,
            },
        }
    }
}

/// Puts `first` and the frames queued after it for the same addresses into
/// `datagram`, up to [`MAX_DATAGRAM`]; returns the frame that did not fit
/// or goes elsewhere (the next datagram's first).
fn fill_datagram(first: LinkFrame, rx: &mut mpsc::Receiver<LinkFrame>, datagram: &mut Vec<u8>) -> Option<LinkFrame> {
    datagram.clear();
    datagram.extend_from_slice(&first.bytes);
    while let Ok(frame) = rx.try_recv() {
        if frame.to != first.to || datagram.len() + frame.bytes.len() > MAX_DATAGRAM {
            return Some(frame);
        }
        datagram.extend_from_slice(&frame.bytes);
    }
    None
}
