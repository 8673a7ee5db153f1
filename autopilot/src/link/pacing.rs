//! Bulk replies on a link (no I/O): which messages are bulk, and when the
//! next one may enter the link's queue.
//!
//! Bulk replies — a parameter list, mission items, FTP and log data — are
//! what a ground station asked for and counts on: they are never dropped
//! for a full queue. The hub keeps them in a backlog per link and moves
//! them into the link's queue as fast as the link drains it:
//! - every link keeps [`RESERVED_SLOTS`] of its queue for telemetry and
//!   other messages, which are dropped (and counted) when the queue is full;
//! - a network link (TCP, UDP) takes bulk while its queue has room: its
//!   writer drains the queue as fast as the socket takes bytes, and a TCP
//!   socket's send buffer pushes back on a slow client;
//! - a serial link (telemetry radio) holds at most [`SERIAL_QUEUE_TIME`] of
//!   transmission at its baud rate (10 bits a byte), so telemetry never
//!   waits behind seconds of parameters; and when the radio reports its own
//!   transmit buffer (RADIO_STATUS `txbuf`, percent free) filling because
//!   the air is slower than the serial port, that allowance shrinks with
//!   the free share, down to nothing at [`RADIO_TXBUF_STOP`] percent — as
//!   ArduPilot slows its sending on the same report. A report older than
//!   [`RADIO_STATUS_STALE`] no longer counts (a radio that went quiet must
//!   not stall the link).

use std::time::Duration;

use mavlink::dialects::ardupilotmega::MavMessage;

use super::hub::LINK_QUEUE;

/// Queue slots bulk replies leave free for everything else.
pub const RESERVED_SLOTS: usize = LINK_QUEUE / 4;
/// Transmission time a serial link's queue may hold.
pub const SERIAL_QUEUE_TIME: Duration = Duration::from_millis(100);
/// At or below this free share of the radio's buffer, no new bulk.
pub const RADIO_TXBUF_STOP: u8 = 20;
/// A RADIO_STATUS this old no longer paces the link.
pub const RADIO_STATUS_STALE: Duration = Duration::from_secs(3);

/// Whether a message is a bulk reply: never dropped, paced to the link.
/// (The deprecated float mission messages still answer clients that use
/// them.)
#[allow(deprecated)]
pub fn is_bulk(message: &MavMessage) -> bool {
    matches!(
        message,
        MavMessage::PARAM_VALUE(_)
            | MavMessage::PARAM_ERROR(_)
            | MavMessage::MISSION_COUNT(_)
            | MavMessage::MISSION_ITEM_INT(_)
            | MavMessage::MISSION_ITEM(_)
            | MavMessage::MISSION_REQUEST_INT(_)
            | MavMessage::MISSION_REQUEST(_)
            | MavMessage::MISSION_ACK(_)
            | MavMessage::FILE_TRANSFER_PROTOCOL(_)
            | MavMessage::LOG_ENTRY(_)
            | MavMessage::LOG_DATA(_)
    )
}

/// What kind of link paces its bulk replies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkPace {
    /// TCP or UDP: as fast as the queue drains.
    Network,
    /// A serial port at this baud rate.
    Serial { baud: u32 },
}

/// One link's pacing state.
#[derive(Clone, Copy, Debug)]
pub struct BulkPacer {
    pace: LinkPace,
    /// The radio's last `txbuf` (percent free) and when it came.
    radio: Option<(u8, Duration)>,
}

impl BulkPacer {
    pub fn new(pace: LinkPace) -> Self {
        BulkPacer { pace, radio: None }
    }

    /// A RADIO_STATUS heard on this link at `now`.
    pub fn radio_status(&mut self, txbuf_percent_free: u8, now: Duration) {
        self.radio = Some((txbuf_percent_free.min(100), now));
    }

    /// Whether a bulk frame of `frame_bytes` may enter the link's queue now,
    /// with `free_slots` left in it and `queued_bytes` not yet written.
    pub fn admits(&self, now: Duration, free_slots: usize, queued_bytes: usize, frame_bytes: usize) -> bool {
        if free_slots <= RESERVED_SLOTS {
            return false;
        }
        let LinkPace::Serial { baud } = self.pace else {
            return true;
        };
        let allowance = self.serial_allowance_bytes(baud, now);
        // One frame always goes when nothing is queued, so a frame larger
        // than the allowance (a slow port) still moves.
        allowance > 0 && (queued_bytes == 0 || queued_bytes + frame_bytes <= allowance)
    }

    /// Bytes a serial link may hold queued: [`SERIAL_QUEUE_TIME`] at the
    /// baud rate, scaled down by a filling radio buffer.
    fn serial_allowance_bytes(&self, baud: u32, now: Duration) -> usize {
        let bytes_per_s = f64::from(baud) / 10.0;
        let full = bytes_per_s * SERIAL_QUEUE_TIME.as_secs_f64();
        let share = match self.radio {
            Some((txbuf, heard)) if now.saturating_sub(heard) < RADIO_STATUS_STALE => {
                f64::from(txbuf.saturating_sub(RADIO_TXBUF_STOP)) / f64::from(100 - RADIO_TXBUF_STOP)
            }
            _ => 1.0,
        };
        (full * share) as usize
    }
}

#[cfg(test)]
mod tests {
    use mavlink::dialects::ardupilotmega::{HEARTBEAT_DATA, PARAM_VALUE_DATA};

    use super::*;

    const FRAME: usize = 37;

    fn at(ms: u64) -> Duration {
        Duration::from_millis(ms)
    }

    #[test]
    fn replies_are_bulk_and_telemetry_is_not() {
        assert!(is_bulk(&MavMessage::PARAM_VALUE(PARAM_VALUE_DATA::default())));
        assert!(!is_bulk(&MavMessage::HEARTBEAT(HEARTBEAT_DATA::default())));
    }

    #[test]
    fn a_network_link_takes_bulk_until_only_the_reserve_is_left() {
        let p = BulkPacer::new(LinkPace::Network);
        assert!(p.admits(at(0), LINK_QUEUE, 1_000_000, FRAME));
        assert!(p.admits(at(0), RESERVED_SLOTS + 1, 0, FRAME));
        assert!(!p.admits(at(0), RESERVED_SLOTS, 0, FRAME));
    }

    #[test]
    fn a_serial_link_holds_a_tenth_of_a_second_at_its_baud_rate() {
        // 57600 baud: 5760 bytes/s, 576 bytes in 100 ms.
        let p = BulkPacer::new(LinkPace::Serial { baud: 57_600 });
        assert!(p.admits(at(0), LINK_QUEUE, 576 - FRAME, FRAME));
        assert!(!p.admits(at(0), LINK_QUEUE, 577 - FRAME, FRAME));
        // A frame larger than the allowance still goes on an empty queue.
        let slow = BulkPacer::new(LinkPace::Serial { baud: 1200 });
        assert!(slow.admits(at(0), LINK_QUEUE, 0, 280));
        assert!(!slow.admits(at(0), LINK_QUEUE, 1, 280));
        assert!(
            !p.admits(at(0), RESERVED_SLOTS, 0, FRAME),
            "the reserve holds on serial too"
        );
    }

    #[test]
    fn a_filling_radio_buffer_slows_then_stops_bulk_until_its_report_is_stale() {
        let mut p = BulkPacer::new(LinkPace::Serial { baud: 57_600 });
        p.radio_status(60, at(1000));
        // Half the free share above the stop level: 288 bytes.
        assert!(p.admits(at(1000), LINK_QUEUE, 288 - FRAME, FRAME));
        assert!(!p.admits(at(1000), LINK_QUEUE, 289 - FRAME, FRAME));
        p.radio_status(RADIO_TXBUF_STOP, at(2000));
        assert!(
            !p.admits(at(2000), LINK_QUEUE, 0, FRAME),
            "radio buffer nearly full: nothing"
        );
        let stale = at(2000) + RADIO_STATUS_STALE;
        assert!(
            p.admits(stale, LINK_QUEUE, 0, FRAME),
            "a radio gone quiet does not stall the link"
        );
        p.radio_status(100, at(9000));
        assert!(p.admits(at(9000), LINK_QUEUE, 576 - FRAME, FRAME));
    }
}
