//! Who a link answers (no I/O): the ground stations heard on it.
//!
//! A UDP socket can be reached by anyone, so a peer is an address that sent
//! a valid MAVLink frame the link admits (correctly signed where signing is
//! required), never merely any datagram. Every peer heard within
//! [`PEER_TIMEOUT`] is served, as pymavlink's `udpin` serves every client
//! it heard within its timeout; the one heard last is served however long
//! it stays quiet (a script that sends once and listens), as is the UDP
//! link's configured destination (`udp:HOST:PORT`, the GCS port).
//!
//! A peer is new (and is told the start-up notices) the first time it is
//! heard and again after a silence of [`PEER_TIMEOUT`]. A TCP client or a
//! serial port is the link's only peer, keyed by no address.

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use crate::vehicle::PeerId;

/// A peer silent this long stops being served (unless it was the last one
/// heard) and is new again when it next speaks. Ten missed GCS heartbeats:
/// twice ArduPilot's default GCS failsafe timeout, so a live GCS never ages out.
pub const PEER_TIMEOUT: Duration = Duration::from_secs(10);
/// Peers remembered per link; beyond it the longest silent is forgotten, so
/// a sender cycling through source ports cannot grow the table.
pub const MAX_PEERS: usize = 16;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Heard {
    addr: Option<SocketAddr>,
    id: PeerId,
    last_heard: Duration,
}

/// The peers of one link. Times are since an arbitrary monotonic start.
#[derive(Debug)]
pub struct Peers {
    fixed: Option<(SocketAddr, PeerId)>,
    heard: Vec<Heard>,
    next_id: u32,
    targets: Arc<[SocketAddr]>,
}

impl Peers {
    /// A link that always sends to `fixed` (a UDP link's configured
    /// destination), if any, besides the peers it hears.
    pub fn new(fixed: Option<SocketAddr>) -> Self {
        let mut peers = Peers {
            fixed: None,
            heard: Vec::new(),
            next_id: 0,
            targets: Arc::from(Vec::new()),
        };
        if let Some(addr) = fixed {
            let id = peers.allocate();
            peers.fixed = Some((addr, id));
        }
        peers.refresh(Duration::ZERO);
        peers
    }

    /// The configured destination's peer id (it is told the notices when
    /// the link opens, as it may be listening without speaking).
    pub fn fixed(&self) -> Option<PeerId> {
        self.fixed.map(|(_, id)| id)
    }

    fn allocate(&mut self) -> PeerId {
        let id = PeerId(self.next_id);
        self.next_id = self.next_id.wrapping_add(1);
        id
    }

    /// An admitted frame from `addr` at `now`. Returns the peer's new id
    /// when it is new: never heard, or silent for [`PEER_TIMEOUT`].
    pub fn heard(&mut self, addr: Option<SocketAddr>, now: Duration) -> Option<PeerId> {
        let was_last = self.last_heard().map(|h| h.addr) == Some(addr);
        let joined = match self.heard.iter().position(|h| h.addr == addr) {
            Some(i) if now.saturating_sub(self.heard[i].last_heard) < PEER_TIMEOUT => {
                self.heard[i].last_heard = now;
                None
            }
            Some(i) => {
                let id = self.allocate();
                self.heard[i] = Heard {
                    addr,
                    id,
                    last_heard: now,
                };
                Some(id)
            }
            None => {
                if self.heard.len() == MAX_PEERS
                    && let Some(oldest) = (0..self.heard.len()).min_by_key(|&i| self.heard[i].last_heard)
                {
                    self.heard.swap_remove(oldest);
                }
                let id = self.allocate();
                self.heard.push(Heard {
                    addr,
                    id,
                    last_heard: now,
                });
                Some(id)
            }
        };
        if joined.is_some() || !was_last {
            self.refresh(now);
        }
        joined
    }

    fn last_heard(&self) -> Option<&Heard> {
        self.heard.iter().max_by_key(|h| h.last_heard)
    }

    /// Recomputes who is served at `now` (peers age out between frames).
    pub fn refresh(&mut self, now: Duration) {
        let last = self.last_heard().map(|h| h.id);
        let mut targets: Vec<SocketAddr> = self.fixed.iter().map(|(addr, _)| *addr).collect();
        for h in &self.heard {
            let live = now.saturating_sub(h.last_heard) < PEER_TIMEOUT || Some(h.id) == last;
            if let Some(addr) = h.addr
                && live
                && !targets.contains(&addr)
            {
                targets.push(addr);
            }
        }
        if *targets != *self.targets {
            self.targets = Arc::from(targets);
        }
    }

    /// The addresses the link's messages go to now.
    pub fn targets(&self) -> &Arc<[SocketAddr]> {
        &self.targets
    }

    /// Where a message for one peer goes: `Some(None)` for a link's only
    /// peer (TCP, serial), `None` when that peer is gone.
    pub fn address(&self, id: PeerId) -> Option<Option<SocketAddr>> {
        if let Some((addr, fixed)) = self.fixed
            && fixed == id
        {
            return Some(Some(addr));
        }
        self.heard.iter().find(|h| h.id == id).map(|h| h.addr)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn addr(port: u16) -> SocketAddr {
        SocketAddr::from(([127, 0, 0, 1], port))
    }

    fn secs(s: u64) -> Duration {
        Duration::from_secs(s)
    }

    #[test]
    fn the_configured_destination_is_always_served() {
        let mut peers = Peers::new(Some(addr(14550)));
        assert_eq!(&**peers.targets(), &[addr(14550)]);
        assert_eq!(peers.address(peers.fixed().unwrap()), Some(Some(addr(14550))));
        peers.heard(Some(addr(5000)), secs(1));
        peers.refresh(secs(100));
        assert!(peers.targets().contains(&addr(14550)));
    }

    #[test]
    fn every_live_peer_is_served_and_the_last_heard_never_ages_out() {
        let mut peers = Peers::new(None);
        assert!(peers.targets().is_empty());
        let a = peers.heard(Some(addr(1)), secs(0)).expect("new");
        let b = peers.heard(Some(addr(2)), secs(1)).expect("new");
        assert_ne!(a, b);
        assert_eq!(&**peers.targets(), &[addr(1), addr(2)]);
        assert_eq!(peers.heard(Some(addr(1)), secs(5)), None, "heard again: not new");
        // addr(2) silent for the timeout: dropped; addr(1) is the last heard.
        peers.refresh(secs(11));
        assert_eq!(&**peers.targets(), &[addr(1)]);
        peers.refresh(secs(1000));
        assert_eq!(&**peers.targets(), &[addr(1)], "the last one heard stays");
    }

    #[test]
    fn a_peer_silent_for_the_timeout_is_new_again() {
        let mut peers = Peers::new(None);
        let first = peers.heard(None, secs(0)).expect("new");
        assert_eq!(peers.heard(None, secs(9)), None);
        let again = peers.heard(None, secs(9) + PEER_TIMEOUT).expect("new after a silence");
        assert_ne!(first, again);
        assert_eq!(peers.address(first), None, "the old id is gone");
        assert_eq!(peers.address(again), Some(None));
    }

    #[test]
    fn the_table_is_bounded_and_forgets_the_longest_silent() {
        let mut peers = Peers::new(None);
        for port in 0..(MAX_PEERS as u16 + 5) {
            peers.heard(Some(addr(1000 + port)), Duration::from_millis(u64::from(port)));
        }
        assert_eq!(peers.heard.len(), MAX_PEERS);
        assert!(!peers.targets().contains(&addr(1000)));
        assert!(peers.targets().contains(&addr(1000 + MAX_PEERS as u16 + 4)));
    }
}
