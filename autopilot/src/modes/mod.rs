//! ArduPilot Rover's modes: their numbers (HEARTBEAT `custom_mode`), names
//! and properties. Ground stations decode the mode from the number, so these
//! are fixed by ArduPilot (`Rover/mode.h`). Furrow adds one of its own,
//! MAGNETIC (magnetic-tape following, seed 002), on a number ArduPilot
//! leaves unused (20); a ground station shows it by number.
//!
//! What each mode does each tick, one file per mode, is in `vehicle/modes/`.
//!
//! Sources: docs/references.md §Seed 002.

use std::fmt;

/// Every Rover mode number a ground station may send.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Mode {
    Manual,
    Acro,
    Steering,
    Hold,
    Loiter,
    Follow,
    Simple,
    Dock,
    Circle,
    Auto,
    Rtl,
    SmartRtl,
    Guided,
    Initialising,
    Magnetic,
}

const ALL: [Mode; 15] = [
    Mode::Manual,
    Mode::Acro,
    Mode::Steering,
    Mode::Hold,
    Mode::Loiter,
    Mode::Follow,
    Mode::Simple,
    Mode::Dock,
    Mode::Circle,
    Mode::Auto,
    Mode::Rtl,
    Mode::SmartRtl,
    Mode::Guided,
    Mode::Initialising,
    Mode::Magnetic,
];

impl Mode {
    pub fn number(self) -> u32 {
        match self {
            Mode::Manual => 0,
            Mode::Acro => 1,
            Mode::Steering => 3,
            Mode::Hold => 4,
            Mode::Loiter => 5,
            Mode::Follow => 6,
            Mode::Simple => 7,
            Mode::Dock => 8,
            Mode::Circle => 9,
            Mode::Auto => 10,
            Mode::Rtl => 11,
            Mode::SmartRtl => 12,
            Mode::Guided => 15,
            Mode::Initialising => 16,
            Mode::Magnetic => 20,
        }
    }

    pub fn from_number(number: u32) -> Option<Mode> {
        ALL.iter().copied().find(|m| m.number() == number)
    }

    /// The name pymavlink and MAVProxy use.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Manual => "MANUAL",
            Mode::Acro => "ACRO",
            Mode::Steering => "STEERING",
            Mode::Hold => "HOLD",
            Mode::Loiter => "LOITER",
            Mode::Follow => "FOLLOW",
            Mode::Simple => "SIMPLE",
            Mode::Dock => "DOCK",
            Mode::Circle => "CIRCLE",
            Mode::Auto => "AUTO",
            Mode::Rtl => "RTL",
            Mode::SmartRtl => "SMART_RTL",
            Mode::Guided => "GUIDED",
            Mode::Initialising => "INITIALISING",
            Mode::Magnetic => "MAGNETIC",
        }
    }

    /// Whether Furrow implements the mode. The others keep their numbers so a
    /// ground station's request is refused with a reason, not misread.
    pub fn is_available(self) -> bool {
        matches!(
            self,
            Mode::Manual | Mode::Hold | Mode::Guided | Mode::Rtl | Mode::Auto | Mode::Magnetic
        )
    }

    /// Needs a position estimate to be entered (and to stay in it).
    pub fn requires_position(self) -> bool {
        matches!(
            self,
            Mode::Loiter
                | Mode::Follow
                | Mode::Dock
                | Mode::Circle
                | Mode::Auto
                | Mode::Rtl
                | Mode::SmartRtl
                | Mode::Guided
        )
    }

    /// Drives itself (HEARTBEAT GUIDED_ENABLED flag, NAV_CONTROLLER_OUTPUT).
    pub fn is_autopilot(self) -> bool {
        matches!(
            self,
            Mode::Auto
                | Mode::Guided
                | Mode::Rtl
                | Mode::SmartRtl
                | Mode::Loiter
                | Mode::Circle
                | Mode::Follow
                | Mode::Dock
                | Mode::Magnetic
        )
    }

    /// Uses the operator's sticks (HEARTBEAT MANUAL_INPUT_ENABLED flag).
    pub fn has_manual_input(self) -> bool {
        matches!(self, Mode::Manual | Mode::Acro | Mode::Steering | Mode::Simple)
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_match_ardupilot_rover() {
        let expected = [
            (0, "MANUAL"),
            (1, "ACRO"),
            (3, "STEERING"),
            (4, "HOLD"),
            (5, "LOITER"),
            (10, "AUTO"),
            (11, "RTL"),
            (12, "SMART_RTL"),
            (15, "GUIDED"),
            (16, "INITIALISING"),
        ];
        for (n, name) in expected {
            assert_eq!(Mode::from_number(n).map(Mode::name), Some(name));
        }
        assert_eq!(Mode::from_number(2), None, "LEARNING was removed");
        for m in ALL {
            assert_eq!(Mode::from_number(m.number()), Some(m));
        }
    }
}
