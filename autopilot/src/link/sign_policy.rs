//! Which inbound frames a link acts on once a signing key is set (no I/O).
//!
//! - A secure link (declared so: a USB cable, a local socket) takes every
//!   frame, signed or not, as ArduPilot's USB port does, so a lost key can
//!   be reset there.
//! - Elsewhere a frame whose signature is wrong, replayed or too old is
//!   dropped.
//! - An unsigned frame (MAVLink 1 too) is dropped on a link whose stream
//!   slot is in `SIGN_REQUIRE`, except RADIO_STATUS and RADIO, which radios
//!   send unsigned (mavlink.io; ArduPilot's accept list), and a telemetry
//!   radio's HEARTBEAT, which is routed but not handed to the core: a
//!   forged one could otherwise hold off the GCS failsafe.

use super::signing::Verdict;

const HEARTBEAT_ID: u32 = 0;
const RADIO_STATUS_ID: u32 = 109;
const RADIO_ID: u32 = 166;
/// MAV_COMP_ID_TELEMETRY_RADIO. MAV_COMP_ID_UDP_BRIDGE (240) is not a
/// radio, and anyone on a network can claim it.
const TELEMETRY_RADIO_COMPID: u8 = 68;

/// How a link treats unsigned frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LinkSecurity {
    pub secure: bool,
    /// Its stream slot's bit is set in `SIGN_REQUIRE`.
    pub require_signed: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DropReason {
    Unsigned,
    BadSignature,
    Replayed,
    OutOfWindow,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Admission {
    /// Route it and hand it to the core.
    Accept,
    /// Route it (the router learns the sender) but keep it from the core.
    RouteOnly,
    Drop(DropReason),
}

pub fn admit(verdict: Verdict, link: LinkSecurity, message_id: u32, component_id: u8) -> Admission {
    if link.secure {
        return Admission::Accept;
    }
    match verdict {
        Verdict::SigningOff | Verdict::Signed => Admission::Accept,
        Verdict::BadSignature => Admission::Drop(DropReason::BadSignature),
        Verdict::Replayed => Admission::Drop(DropReason::Replayed),
        Verdict::OutOfWindow => Admission::Drop(DropReason::OutOfWindow),
        Verdict::Unsigned if !link.require_signed => Admission::Accept,
        Verdict::Unsigned if message_id == RADIO_STATUS_ID || message_id == RADIO_ID => Admission::Accept,
        Verdict::Unsigned if message_id == HEARTBEAT_ID && component_id == TELEMETRY_RADIO_COMPID => {
            Admission::RouteOnly
        }
        Verdict::Unsigned => Admission::Drop(DropReason::Unsigned),
    }
}

/// Whether an admitted frame makes its sender a peer the link answers (see
/// [`super::peers`]): where signed frames are required only a correctly
/// signed one does, so an unsigned RADIO_STATUS or radio HEARTBEAT, which
/// anyone can forge, never draws the telemetry to a stranger.
pub fn makes_peer(verdict: Verdict, link: LinkSecurity) -> bool {
    match verdict {
        Verdict::Signed | Verdict::SigningOff => true,
        Verdict::Unsigned => link.secure || !link.require_signed,
        Verdict::BadSignature | Verdict::Replayed | Verdict::OutOfWindow => link.secure,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const REQUIRING: LinkSecurity = LinkSecurity {
        secure: false,
        require_signed: true,
    };
    const OPEN: LinkSecurity = LinkSecurity {
        secure: false,
        require_signed: false,
    };
    const SECURE: LinkSecurity = LinkSecurity {
        secure: true,
        require_signed: true,
    };
    const COMMAND_LONG: u32 = 76;
    const GCS: u8 = 190;

    #[test]
    fn a_requiring_link_drops_unsigned_commands_but_not_radio_status() {
        assert_eq!(
            admit(Verdict::Unsigned, REQUIRING, COMMAND_LONG, GCS),
            Admission::Drop(DropReason::Unsigned)
        );
        assert_eq!(
            admit(Verdict::Unsigned, REQUIRING, RADIO_STATUS_ID, 68),
            Admission::Accept
        );
        assert_eq!(admit(Verdict::Unsigned, REQUIRING, RADIO_ID, GCS), Admission::Accept);
        assert_eq!(admit(Verdict::Signed, REQUIRING, COMMAND_LONG, GCS), Admission::Accept);
    }

    #[test]
    fn only_a_radio_heartbeat_passes_unsigned_and_never_reaches_the_core() {
        assert_eq!(
            admit(Verdict::Unsigned, REQUIRING, HEARTBEAT_ID, TELEMETRY_RADIO_COMPID),
            Admission::RouteOnly
        );
        assert_eq!(
            admit(Verdict::Unsigned, REQUIRING, HEARTBEAT_ID, GCS),
            Admission::Drop(DropReason::Unsigned)
        );
        assert_eq!(
            admit(Verdict::Unsigned, REQUIRING, HEARTBEAT_ID, 240),
            Admission::Drop(DropReason::Unsigned)
        );
    }

    #[test]
    fn bad_signatures_are_dropped_even_where_unsigned_is_fine() {
        for (verdict, reason) in [
            (Verdict::BadSignature, DropReason::BadSignature),
            (Verdict::Replayed, DropReason::Replayed),
            (Verdict::OutOfWindow, DropReason::OutOfWindow),
        ] {
            assert_eq!(admit(verdict, OPEN, COMMAND_LONG, GCS), Admission::Drop(reason));
            assert_eq!(admit(verdict, REQUIRING, RADIO_STATUS_ID, 68), Admission::Drop(reason));
        }
        assert_eq!(admit(Verdict::Unsigned, OPEN, COMMAND_LONG, GCS), Admission::Accept);
    }

    #[test]
    fn a_secure_link_takes_everything() {
        for verdict in [
            Verdict::Unsigned,
            Verdict::BadSignature,
            Verdict::Replayed,
            Verdict::OutOfWindow,
        ] {
            assert_eq!(admit(verdict, SECURE, COMMAND_LONG, GCS), Admission::Accept);
        }
    }

    #[test]
    fn only_a_signed_frame_makes_a_peer_where_signing_is_required() {
        assert!(makes_peer(Verdict::Signed, REQUIRING));
        assert!(!makes_peer(Verdict::Unsigned, REQUIRING));
        assert!(!makes_peer(Verdict::BadSignature, REQUIRING));
        assert!(!makes_peer(Verdict::Replayed, OPEN));
        assert!(makes_peer(Verdict::Unsigned, OPEN));
        assert!(makes_peer(Verdict::SigningOff, REQUIRING));
        assert!(makes_peer(Verdict::Unsigned, SECURE));
    }

    #[test]
    fn without_a_key_everything_passes() {
        assert_eq!(
            admit(Verdict::SigningOff, REQUIRING, COMMAND_LONG, GCS),
            Admission::Accept
        );
    }
}
